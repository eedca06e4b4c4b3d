"""Commands beside a running stream on a faulty line: how fast does the link recover?

A 4-channel stream at 1 kHz runs at 1,000,000 baud while one task reads the board ID as
fast as it can for ``--seconds``; the harness drops, inserts and flips board->host bytes
with probability ``--fault`` each.  Every resync used to wait for a quiet line that a
running stream never gives (the full 0.25 s drain); the figure is read-ID calls per
second, and how many failed.

    .venv/bin/python -m benchmarks.stream_resync --json benchmarks/results/stream-resync.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.board import Board
from arduinoio_async.errors import LinkError
from arduinoio_async.protocol.pins import UNO_ANALOG
from arduinoio_async.sim import VirtualUno

from ._results import command_line, report


async def measure(args: argparse.Namespace) -> dict[str, Any]:
    ok = failed = wrong = samples = 0
    async with (
        VirtualUno(board_id=0x0021, baud=1_000_000, seed=args.seed) as uno,
        Board.open(uno.port, baudrate=1_000_000) as board,
    ):
        channels = list(UNO_ANALOG)[:4]
        async with board.stream(analog=channels, period_ms=1.0) as stream:
            await uno.set_faults(drop=args.fault, insert=args.fault, flip=args.fault)

            async def consume() -> None:
                nonlocal samples
                async for _sample in stream:
                    samples += 1

            async with anyio.create_task_group() as tg:
                tg.start_soon(consume)
                begin = time.monotonic()
                while time.monotonic() - begin < args.seconds:
                    try:
                        board_id = await board.read_id()
                    except LinkError:
                        failed += 1
                        continue
                    ok += 1
                    wrong += board_id != 0x0021
                elapsed = time.monotonic() - begin
                await uno.set_faults(drop=0, insert=0, flip=0)
                tg.cancel_scope.cancel()
        stats = board.link.stats.as_dict()
    return {
        "command": command_line(),
        "seconds": round(elapsed, 2),
        "read_id_ok": ok,
        "read_id_failed": failed,
        "read_id_wrong": wrong,
        "read_id_per_s": round(ok / elapsed, 1),
        "samples": samples,
        "link_stats": stats,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--fault", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args)
    report(result, args.json)


if __name__ == "__main__":
    main()
