"""Streams below 1 ms on the virtual Uno: gaps over a timed run.

Each case streams analog channels at a period and counts what arrives in ``--seconds``
of simulated time (the sample count, so a simulation running behind the wall clock on a
loaded machine does not shorten the run): sequence gaps (samples the board dropped or the
link lost) and the board-side spacing.  ``library`` reads with ``Board.stream``;
``raw`` with bare pyserial in a thread (the host floor: a Python consumer that falls
behind fills the pty, and the harness then drops bytes it cannot hand over).

    .venv/bin/python -m benchmarks.stream_fast --seconds 20 \\
        --json benchmarks/results/stream_fast.json
"""

from __future__ import annotations

import argparse
import functools
import itertools
import json
import operator
import time
from pathlib import Path
from typing import Any

import anyio
import serial

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import UNO_ANALOG
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result

CASES = [
    # (baud, channels, period_us, reader)
    (2_000_000, 4, 250, "raw"),
    (2_000_000, 4, 250, "library"),
    (1_000_000, 6, 500, "library"),
    (1_000_000, 3, 250, "library"),
]


def _raw(port: str, baud: int, mask: int, period_us: int, count: int) -> list[int]:
    start = p.StreamStart(mask, p.StreamFlags.NONE, period_us).encode()
    size = 12 + 2 * mask.bit_count()
    sequences: list[int] = []
    with serial.Serial(port, baud, timeout=1) as link:
        link.write(start)
        if link.read(len(start)) != start:
            raise RuntimeError("no echo of STREAM START")
        buffer = b""
        deadline = time.monotonic() + count * period_us / 1e6 * 10 + 30
        while len(sequences) < count and time.monotonic() < deadline:
            buffer += link.read(max(1, link.in_waiting))
            while len(buffer) >= size:
                frame, buffer = buffer[:size], buffer[size:]
                if frame[0] != 0x40 or functools.reduce(operator.xor, frame):
                    raise RuntimeError(f"bad frame {frame.hex()}")
                sequences.append(int.from_bytes(frame[4:6]))
    return sequences


async def measure(baud: int, channels: int, period_us: int, reader: str, seconds: float) -> Any:
    mask = (1 << channels) - 1
    count = int(seconds * 1e6 / period_us)
    async with VirtualUno(board_id=1, baud=baud) as uno:
        if reader == "raw":
            sequences = await anyio.to_thread.run_sync(_raw, uno.port, baud, mask, period_us, count)
            spacing: list[int] = []
        else:
            sequences, spacing = [], []
            pins = list(UNO_ANALOG)[:channels]
            async with (
                Board.open(uno.port, baudrate=baud) as board,
                board.stream(analog=pins, period_ms=period_us / 1000, buffer=1_000_000) as stream,
            ):
                previous = None
                async for sample in stream:
                    sequences.append(sample.sequence)
                    if previous is not None:
                        spacing.append((sample.board_time_us - previous) & 0xFFFFFFFF)
                    previous = sample.board_time_us
                    if len(sequences) >= count:
                        break
        status = await uno.status()
    gaps = sum(((b - a) & 0xFFFF) - 1 for a, b in itertools.pairwise(sequences))
    return {
        "baud": baud,
        "channels": channels,
        "period_us": period_us,
        "reader": reader,
        "samples": len(sequences),
        "gaps": gaps,
        "spacing_us": [min(spacing), max(spacing)] if spacing else None,
        "harness_rebases": status["rebases"],
    }


async def main(args: argparse.Namespace) -> None:
    results = []
    for case in CASES:
        result = await measure(*case, seconds=args.seconds)
        results.append(result)
        print(json.dumps(result), flush=True)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_result(args.json, {"command": command_line(), "results": results})


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per case")
    parser.add_argument("--json", type=Path)
    anyio.run(main, parser.parse_args())
