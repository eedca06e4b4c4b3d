"""Boards served elsewhere, with the same ``Board`` API as boards on a local port.

:class:`RemoteBoards` is the network's counterpart of the
:class:`~arduinoio_async.manager.BoardManager`: it watches the boards' liveliness tokens,
and for each board asked for it runs a supervisor like the manager's -- a ``Transport``
on a :class:`~._stream.RemoteByteStream`, a ``Board`` on that, the board's keepalive --
that re-attaches the *same* ``Board`` (replaying its pin roles and failsafe) whenever the
board comes back: after the server's board was replugged, reset, or the server itself
restarted.  :class:`NetworkBoardManager` finds boards by ID on local ports and on the
network alike.
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import NoReturn

import anyio
import anyio.abc
import zenoh

from .._supervisor import Events, ManagerEvent, retry_forever, supervise_link
from ..board import READY_TIMEOUT, Board
from ..errors import BoardNotFoundError, DuplicateBoardError, UsageError
from ..manager import BoardManager
from ..transport import DEFAULT_TIMEOUT
from ._keys import (
    ALL_BOARDS,
    DEFAULT_ENDPOINT,
    announcement_from_key,
    client_key,
    undeclare,
    zenoh_config,
)
from ._loop import LoopHandle
from ._stream import RemoteByteStream

__all__ = ["NetworkBoardManager", "RemoteBoards", "open_remote_board", "parse_board_url"]

log = logging.getLogger(__name__)

SCHEME = "zenoh://"
#: Pause before reconnecting to a board that is announced but did not answer.
RETRY_DELAY = 0.2


def parse_board_url(url: str) -> tuple[int, list[str]]:
    """``zenoh://0x0007`` or ``zenoh://0x0007@tcp/10.0.0.2:7447`` -> (ID, endpoints)."""
    if not url.startswith(SCHEME):
        raise UsageError(f"{url!r} is not a zenoh:// board URL")
    text, _, endpoint = url[len(SCHEME) :].partition("@")
    try:
        board_id = int(text, 0)
    except ValueError:
        raise UsageError(f"{url!r}: {text!r} is not a board ID (e.g. 0x0007)") from None
    if not 0 <= board_id <= 0xFFFF:
        raise UsageError(f"{url!r}: board IDs are 0x0000-0xFFFF")
    return board_id, [endpoint] if endpoint else []


@dataclass
class RemoteBoards:
    """Boards served on the Zenoh network, by ID: ``await remote.get(0x0007)``.

    Give ``connect`` endpoints (default: ``arduinoio serve`` on this machine), a Zenoh
    JSON5 ``config_file`` (TLS, access control), or an open ``session`` to share.
    """

    connect: Sequence[str] = ()
    config_file: str | Path | None = None
    session: zenoh.Session | None = None
    timeout: float = DEFAULT_TIMEOUT
    ready_timeout: float = READY_TIMEOUT
    client_id: str = field(default_factory=lambda: uuid.uuid4().hex)
    _own_session: bool = field(default=False, init=False)
    _announced: dict[int, set[str]] = field(default_factory=dict, init=False)
    _boards: dict[int, Board] = field(default_factory=dict, init=False)
    _supervised: set[int] = field(default_factory=set, init=False)
    _events: Events = field(default_factory=lambda: Events(log), init=False)
    _task_group: anyio.abc.TaskGroup | None = field(default=None, init=False)
    _exit: list[Callable[[], None]] = field(default_factory=list, init=False)

    async def __aenter__(self) -> RemoteBoards:
        if self.session is None:
            connect = list(self.connect) or ([] if self.config_file else [DEFAULT_ENDPOINT])
            config = zenoh_config(connect=connect, config_file=self.config_file)
            self.session = await anyio.to_thread.run_sync(zenoh.open, config)
            self._own_session = True
        session = self.session
        loop = LoopHandle()
        token = session.liveliness().declare_token(client_key(self.client_id))
        watcher = session.liveliness().declare_subscriber(
            ALL_BOARDS,
            loop.forward(self._on_token),
            history=True,
        )
        self._exit = [partial(undeclare, watcher), partial(undeclare, token)]
        self._task_group = anyio.create_task_group()
        await self._task_group.__aenter__()
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        if self._task_group is not None:
            self._task_group.cancel_scope.cancel()
            group, self._task_group = self._task_group, None
            await group.__aexit__(None, None, None)
        for board in self._boards.values():
            board.detach()
        for forget in self._exit:
            forget()
        if self._own_session and self.session is not None:
            session, self.session = self.session, None
            await anyio.to_thread.run_sync(session.close)

    # ---- public API ------------------------------------------------------------------

    def announced(self) -> set[int]:
        """IDs of the boards some server announces right now."""
        return set(self._announced)

    def servers(self, board_id: int) -> set[str]:
        """The servers (Zenoh session IDs) that announce board ``board_id`` right now."""
        return set(self._announced.get(board_id, ()))

    async def wait_announced(self, board_id: int, *, servers: int = 1) -> set[str]:
        """Wait until exactly ``servers`` servers announce ``board_id``; return them."""
        while len(self._announced.get(board_id, ())) != servers:
            await self._events.changed()
        return self.servers(board_id)

    def check_unique(self, board_id: int) -> None:
        """Raise :class:`DuplicateBoardError` if two servers announce ``board_id``.

        The ID then names two boards: a query would reach either, so the board is not
        connected (and a connected one is dropped) until only one server announces it.
        """
        servers = self._announced.get(board_id, set())
        if len(servers) > 1:
            raise DuplicateBoardError(board_id, (f"zenoh server {zid}" for zid in servers))

    def present(self) -> dict[int, Board]:
        """Remote boards this client is connected to, by ID."""
        return {bid: board for bid, board in self._boards.items() if board.connected}

    def subscribe(self, callback: Callable[[ManagerEvent], None]) -> Callable[[], None]:
        """Call ``callback`` on every connect, disconnect, reset and failsafe re-arm."""
        return self._events.subscribe(callback)

    async def get(self, board_id: int, *, timeout: float | None = None) -> Board:
        """The remote board ``board_id``, waiting up to ``timeout`` for it to connect."""
        limit = self.ready_timeout if timeout is None else timeout
        self.check_unique(board_id)
        with anyio.move_on_after(limit):
            return await self.wait_connected(board_id)
        why = (
            "announced, but it did not answer"
            if board_id in self._announced
            else ("no server announces it")
        )
        raise BoardNotFoundError(board_id, {"zenoh": why})

    async def wait_connected(self, board_id: int) -> Board:
        """Wait (without limit) until the remote board ``board_id`` is connected.

        Raises :class:`DuplicateBoardError` as soon as two servers announce the ID.
        """
        if board_id not in self._supervised:
            if self._task_group is None:
                raise RuntimeError("RemoteBoards is not running (use it as a context manager)")
            self._supervised.add(board_id)
            self._task_group.start_soon(self._supervise, board_id, name=f"remote 0x{board_id:04X}")
        while True:
            self.check_unique(board_id)
            board = self._boards.get(board_id)
            if board is not None and board.connected:
                return board
            await self._events.changed()

    # ---- internals -------------------------------------------------------------------

    def _on_token(self, sample: zenoh.Sample) -> None:
        announcement = announcement_from_key(str(sample.key_expr))
        if announcement is None:
            return
        board_id, server = announcement
        servers = self._announced.setdefault(board_id, set())
        if sample.kind == zenoh.SampleKind.PUT:
            servers.add(server)
        else:
            servers.discard(server)
            if not servers:
                del self._announced[board_id]
        self._events.wake()

    async def _supervise(self, board_id: int) -> NoReturn:
        """Connect whenever the board is announced; keep the same Board across links."""

        async def connect_and_run() -> None:
            while len(self._announced.get(board_id, ())) != 1:
                await self._events.changed()
            assert self.session is not None
            stream = RemoteByteStream(self.session, board_id, self.client_id)
            link = await Board.start_link(
                stream, timeout=self.timeout, ready_timeout=self.ready_timeout
            )
            stream.relay_failures_to(link.relay_failure)
            await supervise_link(
                board_id, link, self._boards, self._events, watch=self._until_duplicated
            )

        # A failure is an announced board not answering (yet): the server is restarting,
        # or access control lets us see the token but not query.
        await retry_forever(
            connect_and_run, pause=RETRY_DELAY, what=f"remote board 0x{board_id:04X}", log=log
        )

    async def _until_duplicated(self, board: Board) -> str:
        """Return once two servers announce ``board``'s ID: the link is given up then."""
        while len(self._announced.get(board.board_id, ())) <= 1:
            await self._events.changed()
        log.warning("remote board 0x%04X: two servers announce it; dropped", board.board_id)
        return "two servers announce it"


@asynccontextmanager
async def open_remote_board(
    board: int | str,
    *,
    connect: Sequence[str] = (),
    config_file: str | Path | None = None,
    session: zenoh.Session | None = None,
    timeout: float = DEFAULT_TIMEOUT,
    ready_timeout: float = READY_TIMEOUT,
) -> AsyncIterator[Board]:
    """The board ``board`` (an ID or a ``zenoh://0x0007[@endpoint]`` URL) served remotely.

    The ``Board`` is the same class as for a local port; it survives the server's
    replugs and resets (its roles and failsafe are restored) while the context is open.
    """
    if isinstance(board, str):
        board_id, endpoints = parse_board_url(board)
        connect = [*connect, *endpoints]
    else:
        board_id = board
    async with RemoteBoards(
        connect=connect,
        config_file=config_file,
        session=session,
        timeout=timeout,
        ready_timeout=ready_timeout,
    ) as remote:
        yield await remote.get(board_id)


@dataclass
class NetworkBoardManager(BoardManager):
    """A :class:`BoardManager` that also finds boards served on the Zenoh network.

    A board on a local port is preferred; otherwise ``get()`` returns the remote board
    with the ID, with the same API.
    """

    connect: Sequence[str] = ()
    config_file: str | Path | None = None
    remote: RemoteBoards | None = field(default=None, init=False)

    async def __aenter__(self) -> NetworkBoardManager:
        self.remote = RemoteBoards(
            connect=self.connect,
            config_file=self.config_file,
            timeout=self.timeout,
            ready_timeout=self.probe_deadline,
        )
        await self.remote.__aenter__()
        try:
            await super().__aenter__()
        except BaseException:
            await self.remote.__aexit__(None, None, None)
            raise
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        try:
            await super().__aexit__(*exc_info)
        finally:
            if self.remote is not None:
                await self.remote.__aexit__(*exc_info)

    def present(self) -> dict[int, Board]:
        """Connected boards by ID, local and remote; a local board wins an ID both have."""
        remote = self.remote.present() if self.remote is not None else {}
        return {**remote, **super().present()}

    async def get(self, board_id: int, *, timeout: float | None = None) -> Board:
        """The board ``board_id`` on a local port or on the network, waiting up to
        ``timeout`` seconds; BoardNotFoundError says what each way tried found."""
        if self.remote is not None:
            self.remote.check_unique(board_id)
        try:
            return await super().get(board_id, timeout=timeout)
        except BoardNotFoundError as exc:
            tried = dict(exc.tried)
            tried["zenoh"] = (
                "announced, but it did not answer"
                if self.remote is not None and board_id in self.remote.announced()
                else "no server announces it"
            )
            raise BoardNotFoundError(board_id, tried) from None

    async def wait_connected(self, board_id: int) -> Board:
        """Wait (without limit) until the board ``board_id`` is connected, locally or on
        the network, whichever comes first."""
        local = super().present().get(board_id)
        if local is not None or self.remote is None:
            return await super().wait_connected(board_id)
        found: list[Board] = []
        remote = self.remote

        async with anyio.create_task_group() as tg:

            async def first(wait: Callable[[int], Awaitable[Board]]) -> None:
                found.append(await wait(board_id))
                tg.cancel_scope.cancel()

            tg.start_soon(first, partial(BoardManager.wait_connected, self))
            tg.start_soon(first, remote.wait_connected)
        return found[0]
