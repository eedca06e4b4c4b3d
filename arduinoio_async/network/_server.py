"""``arduinoio serve``: the boards of a local BoardManager, served on a Zenoh session.

The server follows its manager: each board the manager connects is served
(:class:`~._served_board.ServedBoard`, whose docstring is the theory of operation: how a
query reaches the board, virtual sessions, the failsafe's owner) until the manager loses
it; the manager's connection events are published for remote managers, and the
liveliness of every client is watched so that a vanished client's failsafe and stream are
dealt with.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Callable
from typing import Any

import anyio
import anyio.abc
import zenoh
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from ..board import Board
from ..manager import BoardManager, ManagerEvent
from ._keys import ALL_CLIENTS, connection_key, undeclare
from ._loop import LoopHandle
from ._served_board import ServedBoard

__all__ = ["BoardServer"]

log = logging.getLogger(__name__)

#: A function and its arguments, to start in the server's task group.
_Spawn = tuple[Callable[..., Any], tuple[Any, ...]]


class BoardServer:
    """Serves every board of ``manager`` on ``session`` until cancelled.

    ``async with BoardManager(...) as boards: await BoardServer(boards, session).run()``
    """

    def __init__(self, manager: BoardManager, session: zenoh.Session) -> None:
        self.manager = manager
        self.session = session
        self.served: dict[int, ServedBoard] = {}
        self._task_group: anyio.abc.TaskGroup | None = None
        self._spawn: MemoryObjectSendStream[_Spawn] | None = None
        self._loop: LoopHandle | None = None

    @property
    def loop(self) -> LoopHandle:
        """The server's event loop, for Zenoh's callbacks to schedule work in (only while
        the server runs)."""
        assert self._loop is not None, "the server is not running"
        return self._loop

    def start_soon(self, func: Any, *args: Any) -> None:
        """Start ``func(*args)`` in the server's task group, from any code in the loop.

        Zenoh's callbacks reach the loop as plain callbacks (``call_soon_threadsafe``),
        outside any task, where a task group cannot spawn; so spawning goes through a
        queue that a task of the group serves.
        """
        if self._spawn is not None:
            self._spawn.send_nowait((func, args))

    async def _spawner(
        self, tg: anyio.abc.TaskGroup, requests: MemoryObjectReceiveStream[_Spawn]
    ) -> None:
        async with requests:
            async for func, args in requests:
                tg.start_soon(func, *args)

    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Serve until cancelled; ``task_status.started()`` once the present boards are up."""
        self._loop = LoopHandle()
        loop = self._loop
        clients = self.session.liveliness().declare_subscriber(
            ALL_CLIENTS,
            loop.forward(self._on_client),
        )
        unsubscribe = self.manager.subscribe(self._on_manager_event)
        try:
            async with anyio.create_task_group() as tg:
                self._task_group = tg
                self._spawn, requests = anyio.create_memory_object_stream[_Spawn](math.inf)
                tg.start_soon(self._spawner, tg, requests)
                for board in self.manager.present().values():
                    self._serve(board)
                task_status.started()
                await anyio.sleep_forever()
        finally:
            self._task_group = None
            if self._spawn is not None:
                self._spawn.close()
                self._spawn = None
            unsubscribe()
            for served in self.served.values():
                served.close()
            self.served.clear()
            undeclare(clients)

    def _serve(self, board: Board) -> None:
        old = self.served.pop(board.board_id, None)
        if old is not None:
            old.close()
        if board.connected:
            self.served[board.board_id] = ServedBoard(self, board)
            log.info("serving board 0x%04X from %s", board.board_id, board.port)

    def _on_manager_event(self, event: ManagerEvent) -> None:
        if event.kind == "connected":
            board = self.manager.present().get(event.board_id)
            if board is not None:
                self._serve(board)
        elif event.kind == "disconnected":
            served = self.served.get(event.board_id)
            if served is not None and served.link.name == event.port:
                self.served.pop(event.board_id).close()
        self._publish_event(event)

    def _publish_event(self, event: ManagerEvent) -> None:
        if event.kind == "failsafe":
            return  # the trip itself is on the event key; re-arming is the clients' job
        message = {"kind": event.kind, "port": event.port, "detail": event.detail}
        try:
            self.session.put(connection_key(event.board_id), json.dumps(message).encode())
        except zenoh.ZError as exc:
            log.debug("connection event not published: %s", exc)

    def _on_client(self, sample: zenoh.Sample) -> None:
        if sample.kind != zenoh.SampleKind.DELETE:
            return
        client = str(sample.key_expr).rsplit("/", 1)[-1]
        for served in list(self.served.values()):
            served.client_gone(client)
