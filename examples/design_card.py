"""The design card's line against a board: a real one, or a virtual Uno started here.

.venv/bin/python examples/design_card.py              # starts a virtual Uno (loopback)
.venv/bin/python examples/design_card.py /dev/ttyACM0 # a real board
"""

from __future__ import annotations

import sys

import anyio

from arduinoio_async import D2, D3
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno


async def blink(port: str) -> None:
    async with Board.open(port) as board:
        await board.gpio(D2).write(True)  # the design card's line
        print(
            f"{board}: D2 high; D3 (jumpered to D2 on the test circuit) reads",
            await board.gpio(D3).read(),
        )


async def main() -> None:
    if len(sys.argv) > 1:
        await blink(sys.argv[1])
        return
    async with VirtualUno(board_id=0x0102, fixture="loopback") as uno:
        await blink(uno.port)


if __name__ == "__main__":
    anyio.run(main)
