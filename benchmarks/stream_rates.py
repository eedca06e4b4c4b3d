"""Sustained stream rate and loss on the virtual Uno (issue: streaming beyond the paper).

For 1, 4 and 6 analog channels at 115200 and 1,000,000 baud, stream at the highest rate
the board admits for ``--seconds`` and count what arrives, the sequence gaps and the
consumer-side drops.  The paper could not read four channels every 10 ms (100 Hz);
Firmata reports at most about 1 kHz, without loss detection.

    .venv/bin/python -m benchmarks.stream_rates --seconds 60 --json benchmarks/results/stream.json
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import UNO_ANALOG
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result


async def measure(baud: int, channels: int, seconds: float) -> dict[str, Any]:
    mask = (1 << channels) - 1
    period_us = p.stream_min_period_us(mask, p.StreamFlags.NONE, baud)
    pins = list(UNO_ANALOG)[:channels]
    spacing: list[int] = []
    received = 0
    async with (
        VirtualUno(board_id=1, baud=baud) as uno,
        Board.open(uno.port, baudrate=baud) as board,
    ):
        async with board.stream(analog=pins, period_ms=period_us / 1000) as stream:
            start = time.monotonic()
            previous = None
            async for sample in stream:
                received += 1
                if previous is not None:
                    spacing.append((sample.board_time_us - previous) & 0xFFFFFFFF)
                previous = sample.board_time_us
                if sample.host_time - start >= seconds:
                    break
            elapsed = time.monotonic() - start
        gaps, dropped = stream.gaps, stream.dropped
    return {
        "baud": baud,
        "channels": channels,
        "period_us": period_us,
        "seconds": round(elapsed, 3),
        "received": received,
        "rate_hz": round(received / elapsed, 1),
        "gaps": gaps,
        "dropped": dropped,
        "loss": (gaps + dropped) / max(1, received + gaps + dropped),
        "spacing_us": {
            "min": min(spacing),
            "max": max(spacing),
            "mean": round(statistics.fmean(spacing), 3),
            "stdev": round(statistics.pstdev(spacing), 3),
        },
    }


async def main(args: argparse.Namespace) -> None:
    results = []
    for baud in (115_200, 1_000_000):
        for channels in (1, 4, 6):
            result = await measure(baud, channels, args.seconds)
            results.append(result)
            print(json.dumps(result))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_result(
            args.json,
            {
                "command": command_line(),
                "seconds": args.seconds,
                "results": results,
            },
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--json", type=Path)
    anyio.run(main, parser.parse_args())
