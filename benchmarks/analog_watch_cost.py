"""What watching analog channels costs the link: READ ID and ANALOG READ round trips on
the virtual Uno (1 Mbaud, no bridge) with no channel watched and with all six watched
(deadband 1000: the board samples, nothing moves, no event), interleaved in blocks of 200;
the median of the block medians and their spread.

An ANALOG READ may wait for a watch conversion in flight (at most 104 us, one in five
ticks); a READ ID never waits for the ADC.

    .venv/bin/python -m benchmarks.analog_watch_cost
"""

from __future__ import annotations

import statistics
import time
from contextlib import AsyncExitStack

import anyio

from arduinoio_async import A0, A1, A2, A3, A4, A5
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno

BLOCKS = 8
PER_BLOCK = 200


async def block(board: Board, what: str) -> float:
    a0 = board.analog(A0)
    times = []
    for _ in range(PER_BLOCK):
        start = time.perf_counter()
        if what == "read id":
            await board.read_id()
        else:
            await a0.read()
        times.append((time.perf_counter() - start) * 1e6)
    return statistics.median(times)


async def main() -> None:
    results: dict[tuple[str, str], list[float]] = {}
    async with (
        VirtualUno(board_id=1, baud=1_000_000) as uno,
        Board.open(uno.port, baudrate=uno.baud) as board,
    ):
        for _ in range(BLOCKS):
            for mode in ("none watched", "6 watched"):
                async with AsyncExitStack() as stack:
                    if mode == "6 watched":
                        for pin in (A0, A1, A2, A3, A4, A5):
                            await stack.enter_async_context(board.analog(pin).watch(deadband=1000))
                    for what in ("read id", "analog read"):
                        results.setdefault((what, mode), []).append(await block(board, what))
    for (what, mode), medians in results.items():
        print(
            f"{what:11s} {mode:12s} median {statistics.median(medians):6.1f} us "
            f"(block medians {min(medians):.1f}-{max(medians):.1f}, {BLOCKS} x {PER_BLOCK})"
        )


if __name__ == "__main__":
    anyio.run(main)
