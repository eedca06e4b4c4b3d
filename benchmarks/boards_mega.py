"""Table IV on the virtual Mega 2560 (issue 29): p50 per command, one request in flight.

The paper's commands (``arduinoio_async.bench.commands``) on the Mega image running on
simavr's ATmega2560 core (``VirtualUno(board="mega2560")``): at 115200 baud through the
16U2 bridge model (the paper's setup) and at 1,000,000 baud without a bridge.  "read
temperature" is left out: the ATmega2560 has no temperature sensor (the image answers
NOT_IN_IMAGE).  Each request waits a random pause first, so requests meet the bridge's
4.096 ms tick at a random phase.  State the machine's load (recorded) when comparing.

    .venv/bin/python -m benchmarks.boards_mega --json benchmarks/results/boards-mega.json
"""

from __future__ import annotations

import argparse
import os
import random
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.bench.commands import COMMANDS, prepare
from arduinoio_async.bench.stats import summarize
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.virtual_uno import UsbBridge

from ._results import command_line, write_result
from ._timing import blocking_pause

#: (baud, bridge model): the paper's link and the fast one.
SCENARIOS: tuple[tuple[int, UsbBridge], ...] = ((115200, "16u2"), (1_000_000, "none"))
#: Random pause before each request: two 16U2 ticks.
PAUSE_S = 0.008192
#: Not on the ATmega2560.
LEFT_OUT = ("read temperature",)


async def table(baud: int, bridge: UsbBridge, n: int) -> list[dict[str, Any]]:
    rows = []
    # two statements: the port exists only once the virtual Mega runs
    async with VirtualUno(board="mega2560", board_id=1, baud=baud, usb_bridge=bridge) as mega:  # noqa: SIM117
        async with Board.open(mega.port, baudrate=baud) as board:
            await prepare(board)
            for command in COMMANDS:
                if command.name in LEFT_OUT:
                    continue
                call = command.call(board)
                samples = []
                for _ in range(n):
                    await blocking_pause(random.uniform(0.0, PAUSE_S))
                    start = time.perf_counter()
                    await call()
                    samples.append((time.perf_counter() - start) * 1000.0)
                stats = summarize(samples).rounded(3, "_ms")
                rows.append({"command": command.name, "paper_ms": command.paper_ms, **stats})
                print(f"{baud:>8} {bridge:>5} {command.name:<24} p50 {stats['p50_ms']:.3f} ms")
    return rows


async def main(args: argparse.Namespace) -> int:
    load_before = os.getloadavg()
    scenarios = []
    for baud, bridge in SCENARIOS:
        rows = await table(baud, bridge, args.n)
        scenarios.append({"board": "mega2560", "baud": baud, "usb_bridge": bridge, "rows": rows})
    if args.json:
        write_result(
            args.json,
            {
                "command": command_line(),
                "machine": {
                    "cpus": os.cpu_count(),
                    "load_average_before": load_before,
                    "load_average_after": os.getloadavg(),
                },
                "left_out": list(LEFT_OUT),
                "scenarios": scenarios,
            },
        )
    return 0


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--n", type=int, default=200, help="requests per command")
    return parser.parse_args()


if __name__ == "__main__":
    raise SystemExit(anyio.run(main, parse_args()))
