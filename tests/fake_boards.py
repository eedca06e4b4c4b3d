"""A Board connected to a FakeBoard, shared by the unit tests of the board's features."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard


@asynccontextmanager
async def connected(board_id: int = 0x0042) -> AsyncIterator[tuple[Board, FakeBoard]]:
    """A board on a fake (not a yield fixture: task groups must exit in their own task)."""
    async with (
        FakeBoard(board_id=board_id) as fake,
        Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as board,
    ):
        yield board, fake
