"""USB bridges (issue 29 item 4): read ID p50 through the virtual Uno's bridge models.

Sequential READ_ID round trips (one in flight, each after a random pause so a request meets
the bridges' clocks at a random phase) on the project firmware, through:

- the FTDI model with the chip's default 16 ms latency timer;
- the FTDI model with the library's setting: the virtual Uno's pty is described as an
  FT232R's tty in a fake sysfs (``testing._fake_sysfs``), the library writes its
  ``latency_timer`` when it opens the port, and the value written is handed to the model
  (``VirtualUno.set_latency_timer``) as ``ftdi_sio`` hands it to the chip;
- the CH340 model (next USB frame);
- the 16U2 model with the board's low-latency mode on (at 1 Mbaud and up, where
  ``Board.open`` turns it on by itself behind a real 16U2) and, for reference, off.

Goal (issue 29): the library's FTDI setting within 1.5x of the 16U2 low-latency p50 at the
same baud rate.  The harness's own figure of how long replies waited in the model
(``status.bridge.hold_*``, simulated time) is recorded next to the host's.

    .venv/bin/python -m benchmarks.boards_bridges --json benchmarks/results/boards.json
"""

from __future__ import annotations

import argparse
import os
import random
import tempfile
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.bench.stats import summarize
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.testing._fake_sysfs import FakeSysfs
from arduinoio_async.transport import _latency

from ._results import command_line, write_result
from ._timing import blocking_pause

GOAL_RATIO = 1.5
#: Random pause before each request: two 16U2 ticks (and so whole USB frames).
PAUSE_S = 0.008192


def figures(samples: list[float]) -> dict[str, Any]:
    """The percentiles of ``arduinoio_async.bench.stats`` and the extremes, in ms."""
    return {
        **summarize(samples).rounded(3, "_ms"),
        "min_ms": round(min(samples), 3),
        "max_ms": round(max(samples), 3),
    }


async def read_ids(board: Board, n: int) -> list[float]:
    out = []
    for _ in range(n):
        await blocking_pause(random.uniform(0.0, PAUSE_S))
        start = time.perf_counter()
        await board.read_id()
        out.append((time.perf_counter() - start) * 1000)
    return out


async def run_config(name: str, bridge: str, baud: int, n: int) -> dict[str, Any]:
    """One configuration on a fresh virtual Uno; ``name`` says what the library sets."""
    with tempfile.TemporaryDirectory() as tmp:
        sysfs = FakeSysfs(Path(tmp))
        async with VirtualUno(usb_bridge=bridge, baud=baud, board_id=0x29) as uno:  # type: ignore[arg-type]
            written: int | None = None
            tty = ""
            if name == "ftdi-library":
                tty = await anyio.to_thread.run_sync(sysfs.add_device_of, uno.port, 0x0403, 0x6001)
                _latency.SYSFS_ROOT = str(sysfs.root)
            try:
                async with Board.open(uno.port, baudrate=baud) as board:
                    if name == "ftdi-library":
                        written = await anyio.to_thread.run_sync(sysfs.latency_timer, tty)
                        assert written is not None, "the library wrote no latency_timer"
                        await uno.set_latency_timer(written)
                    if bridge == "16u2":
                        await board.set_low_latency(name == "16u2-low-latency")
                    await read_ids(board, 10)  # warm up
                    if bridge == "ftdi":
                        await uno.set_latency_timer(written or 16)  # hold statistics afresh
                    samples = await read_ids(board, n)
                    status = await uno.status()
                    garbage = board.link.stats.garbage_bytes
            finally:
                _latency.SYSFS_ROOT = "/sys"
    hold = status["bridge"]
    return {
        "config": name,
        "bridge": bridge,
        "baud": baud,
        "latency_timer_written": written,
        **figures(samples),
        "model_hold_us": {k: hold[k] for k in ("holds", "hold_min_us", "hold_max_us")}
        if bridge in ("ftdi", "ch340")
        else None,
        "garbage_bytes": garbage,
    }


CONFIGS = [
    ("ftdi-default-16ms", "ftdi"),
    ("ftdi-library", "ftdi"),
    ("ch340", "ch340"),
    ("16u2-low-latency", "16u2"),
    ("16u2-tick", "16u2"),
]


async def main(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    rows = []
    for baud in args.bauds:
        for name, bridge in CONFIGS:
            if name == "16u2-low-latency" and baud < 1_000_000:
                continue  # the filler outlasts the tick at 115200: the library leaves it off
            rows.append(await run_config(name, bridge, baud, args.n))
            print(f"{baud:>9,} {name:<20} p50 {rows[-1]['p50_ms']:.2f} ms", flush=True)
    goals = []
    for baud in args.bauds:
        by = {row["config"]: row for row in rows if row["baud"] == baud}
        if "16u2-low-latency" in by:
            ratio = by["ftdi-library"]["p50_ms"] / by["16u2-low-latency"]["p50_ms"]
            goals.append(
                {
                    "baud": baud,
                    "ftdi_library_over_16u2_low_latency": round(ratio, 3),
                    "met": ratio <= GOAL_RATIO,
                }
            )
    print("| baud | config | n | p50 ms | mean ms | p90 ms | model hold us (min-max) |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        hold = row["model_hold_us"]
        held = f"{hold['hold_min_us']:.0f}-{hold['hold_max_us']:.0f}" if hold else "-"
        print(
            f"| {row['baud']:,} | {row['config']} | {row['n']} | {row['p50_ms']:.2f} | "
            f"{row['mean_ms']:.2f} | {row['p90_ms']:.2f} | {held} |"
        )
    for goal in goals:
        print(
            f"goal at {goal['baud']:,} baud: FTDI (library) / 16U2 low-latency p50 = "
            f"{goal['ftdi_library_over_16u2_low_latency']} (<= {GOAL_RATIO}: {goal['met']})"
        )
    if args.json:
        result = {
            "command": command_line(),
            "machine": {
                "cpus": os.cpu_count(),
                "load_average_before": load_before,
                "load_average_after": os.getloadavg(),
            },
            "goal_ratio": GOAL_RATIO,
            "goals": goals,
            "rows": rows,
        }
        write_result(args.json, result)
    return 0


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--n", type=int, default=200, help="requests per configuration")
    parser.add_argument("--bauds", type=int, nargs="+", default=[1_000_000, 115200])
    return parser.parse_args()


if __name__ == "__main__":
    raise SystemExit(anyio.run(main, parse_args()))
