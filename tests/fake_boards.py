"""Helpers shared by the tests: a Board connected to a FakeBoard, concurrent callers."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard


async def read_ids_concurrently(board: Board, tasks: int = 8, each: int = 10) -> list[int]:
    """Every answer of ``tasks`` tasks each reading the ID ``each`` times (pipelined)."""
    replies: list[int] = []

    async def read_ids() -> None:
        for _ in range(each):
            replies.append(await board.read_id())

    async with anyio.create_task_group() as tg:
        for _ in range(tasks):
            tg.start_soon(read_ids)
    return replies


@asynccontextmanager
async def connected(board_id: int = 0x0042) -> AsyncIterator[tuple[Board, FakeBoard]]:
    """A board on a fake (not a yield fixture: task groups must exit in their own task)."""
    async with (
        FakeBoard(board_id=board_id) as fake,
        Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as board,
    ):
        yield board, fake
