"""What the CRC slip hold costs (docs/protocol.md 7.7): a free-valued reply that ends a
read waits until the line stayed quiet one byte time.  Measures, on one virtual Uno in
CRC-16 framing, (1) the hold itself: the time from the read that ended on the held reply
to its release, per reply, and how often a byte came first; (2) the round trip of
READ_TEMPERATURE (held) against READ_ID (not held: the identity is expected), interleaved.

    .venv/bin/python -m benchmarks.crc_hold --calls 500 [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.transport import FRAMING_ENV
from arduinoio_async.transport._wire import Wire

from ._results import command_line


async def measure(args: argparse.Namespace) -> dict[str, Any]:
    os.environ[FRAMING_ENV] = "crc16"
    holds: list[float] = []
    started: list[float] = []
    hold, release = Wire._hold_reply, Wire._release_held

    def timed_hold(self: Wire) -> None:
        started.append(time.perf_counter())
        hold(self)

    def timed_release(self: Wire) -> None:
        if started:
            holds.append(time.perf_counter() - started.pop())
        release(self)

    Wire._hold_reply = timed_hold  # type: ignore[method-assign]
    Wire._release_held = timed_release  # type: ignore[method-assign]
    lat: dict[str, list[float]] = {"read_temperature": [], "read_id": []}
    async with (
        VirtualUno(board_id=0x0046, baud=args.baud) as uno,
        Board.open(uno.port, baudrate=args.baud, timeout=2.0) as board,
    ):
        for _ in range(args.calls):
            for name, call in (("read_temperature", board.temperature), ("read_id", board.read_id)):
                t0 = time.perf_counter()
                await call()
                lat[name].append(time.perf_counter() - t0)
    Wire._hold_reply, Wire._release_held = hold, release  # type: ignore[method-assign]
    p50 = {k: round(statistics.median(v) * 1e6, 1) for k, v in lat.items()}
    return {
        "command": command_line(),
        "baud": args.baud,
        "load": os.getloadavg(),
        "calls": args.calls,
        "holds": len(holds),
        "hold_p50_us": round(statistics.median(holds) * 1e6, 1) if holds else None,
        "hold_p90_us": round(statistics.quantiles(holds, n=10)[-1] * 1e6, 1)
        if len(holds) > 10
        else None,
        "round_trip_p50_us": p50,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=500)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args)
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
