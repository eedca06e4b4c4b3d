"""Helpers shared by the tests: a Board connected to a FakeBoard, concurrent callers."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Protocol

import anyio

from arduinoio_async.board import Board
from arduinoio_async.manager import ManagerEvent
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


class Subscribable(Protocol):
    """A BoardManager or RemoteBoards: both tell subscribers about their boards."""

    def subscribe(self, callback: Callable[[ManagerEvent], None]) -> Callable[[], None]: ...


def reset_event(manager: Subscribable) -> anyio.Event:
    """An event set once ``manager`` reports that one of its boards reset."""
    seen = anyio.Event()

    def on_event(event: ManagerEvent) -> None:
        if event.kind == "reset":
            seen.set()

    manager.subscribe(on_event)
    return seen


@asynccontextmanager
async def connected(board_id: int = 0x0042) -> AsyncIterator[tuple[Board, FakeBoard]]:
    """A board on a fake (not a yield fixture: task groups must exit in their own task)."""
    async with (
        FakeBoard(board_id=board_id) as fake,
        Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as board,
    ):
        yield board, fake
