"""Low-latency mode behind the 16U2 bridge model: read ID latency.

Sequential READ_ID round trips (one in flight, each after a random pause) on the project
firmware behind the virtual Uno's 16U2 model (``--usb-bridge 16u2``: board-to-host bytes
wait for the 4.096 ms tick unless more than 96 wait), with low-latency mode off and on.
The modes alternate in blocks of ``--block`` requests on the same board and link, and
every round starts a fresh board per baud rate, so a busy moment of the shared machine
hits both modes.  ``--cpu-idle both`` adds the CPU idle states as a second dimension
(the CPUs' default idle states, or held out of deep ones: :mod:`arduinoio_async.bench.cpu_idle`),
interleaved the same way.
Goal: 2 Mbaud, low-latency mode, mean at most 1.8 ms.

    .venv/bin/python -m benchmarks.low_latency --cpu-idle both \
        --json benchmarks/results/low_latency.json
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.bench import cpu_idle
from arduinoio_async.bench.cpu_idle import ShallowCpuIdle
from arduinoio_async.bench.model import LinkModel
from arduinoio_async.bench.stats import summarize
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result
from ._timing import blocking_pause

GOAL_MEAN_MS = 1.8


def figures(samples: list[float]) -> dict[str, Any]:
    """n, mean, p50, p90, p99 (:mod:`arduinoio_async.bench.stats`), min and max, in ms."""
    summary = summarize(samples).rounded(3, "_ms")
    return {
        "n": summary["n"],
        "mean_ms": summary["mean_ms"],
        **{key: summary[key] for key in ("p50_ms", "p90_ms", "p99_ms")},
        "min_ms": round(min(samples), 3),
        "max_ms": round(max(samples), 3),
    }


#: The 16U2's tick (Timer0 overflow at clk/256): the pause before each request is uniform
#: over two of them (and so over whole 1 ms USB frames), so a request meets the tick and
#: the frames at a random phase, as a robot's command does.  Back to back, a sequential
#: loop locks into the USB frames: two frames a round trip, whatever the mode.
TICK_S = LinkModel().tick_ms / 1000


async def read_ids(board: Board, n: int) -> list[float]:
    out = []
    for _ in range(n):
        await blocking_pause(random.uniform(0.0, 2 * TICK_S))
        start = time.perf_counter()
        await board.read_id()
        out.append((time.perf_counter() - start) * 1000)
    return out


async def main(args: argparse.Namespace, idle: ShallowCpuIdle, conditions: list[str]) -> int:
    runs = [(mode, cond) for cond in conditions for mode in ("off", "on")]
    samples: dict[tuple[int, str, str], list[float]] = {}
    round_means: dict[tuple[int, str, str], list[float]] = {}
    garbage = 0
    for r in range(args.rounds):
        for baud in args.bauds:
            async with (
                VirtualUno(usb_bridge="16u2", baud=baud, board_id=1) as uno,
                Board.open(uno.port, baudrate=baud) as board,
            ):
                await read_ids(board, 10)  # warm up: memo, page cache
                got: dict[tuple[str, str], list[float]] = {run: [] for run in runs}
                for block in range(args.n // args.block):
                    shift = block % len(runs)
                    for mode, cond in runs[shift:] + runs[:shift]:
                        await board.set_low_latency(mode == "on")
                        idle.set(cond)
                        got[mode, cond] += await read_ids(board, args.block)
                        idle.release()
                garbage += board.link.stats.garbage_bytes
            for (mode, cond), values in got.items():
                samples.setdefault((baud, mode, cond), []).extend(values)
                round_means.setdefault((baud, mode, cond), []).append(statistics.fmean(values))
        print(f"round {r + 1} of {args.rounds} done", flush=True)
    rows = [
        {
            "baud": baud,
            "bridge": "16u2",
            "low_latency": mode,
            "cpu_idle": cond,
            **figures(values),
            "round_means_ms": [round(m, 3) for m in round_means[(baud, mode, cond)]],
        }
        for (baud, mode, cond), values in sorted(samples.items(), reverse=True)
    ]
    print(
        "| baud | low latency | CPU idle | n | mean ms | p50 ms | p90 ms | p99 ms | round means |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        means = " ".join(f"{m:.2f}" for m in row["round_means_ms"])
        print(
            f"| {row['baud']:,} | {row['low_latency']} | {row['cpu_idle']} | {row['n']} | "
            f"{row['mean_ms']:.2f} | {row['p50_ms']:.2f} | {row['p90_ms']:.2f} | "
            f"{row['p99_ms']:.2f} | {means} |"
        )
    print(f"garbage bytes seen by the host: {garbage} (filler must never count)")
    if args.json:
        result = {"command": command_line(), "goal_mean_ms": GOAL_MEAN_MS}
        write_result(args.json, {**result, "garbage_bytes": garbage, "rows": rows})
    return 0


def parse_args() -> tuple[argparse.Namespace, ShallowCpuIdle, list[str]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--n", type=int, default=400, help="requests per mode and round")
    parser.add_argument("--block", type=int, default=50, help="requests per mode block")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--bauds", type=int, nargs="+", default=[2_000_000, 1_000_000])
    cpu_idle.add_option(parser, interleave=True)
    args = parser.parse_args()
    return args, *cpu_idle.conditions(parser, args.cpu_idle)


if __name__ == "__main__":
    raise SystemExit(anyio.run(main, *parse_args()))
