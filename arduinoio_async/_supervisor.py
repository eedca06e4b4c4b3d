"""One board's life on one link, shared by the local manager and the remote client.

Theory of operation
-------------------
The :class:`~arduinoio_async.manager.BoardManager` finds boards on local ports and the
:class:`~arduinoio_async.network.RemoteBoards` client finds them on the Zenoh network,
but once a link to a board is up both do the same: attach the board (the *same*
``Board`` object as before, its pin roles, modes and failsafe replayed), tell their
listeners, run the board's keepalive -- which restores the board when it reset by
itself and re-arms its failsafe after a trip -- and, when the link closes, detach the
board and say why.  That is :func:`supervise_link`.  How a link is found (a port scan, a
liveliness token) stays with each caller; the pause-and-try-again loop both use around
their discovery is :func:`retry_forever`, and the news both give is :class:`Events`.

A board that comes back under another ID (its ID rewritten in place) is another board:
its old roles are not replayed on it, the link is given up, and the outcome says so
(the manager probes the port again and attaches it under its new ID).
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from functools import partial
from typing import Literal, NoReturn

import anyio

from . import protocol as p
from .board import Board
from .errors import ArduinoIOError, BoardIdChangedError
from .transport import LinkState, Transport

__all__ = [
    "RETRYABLE",
    "Events",
    "LinkOutcome",
    "ManagerEvent",
    "attach_board",
    "retry_forever",
    "supervise_link",
]

logger = logging.getLogger(__name__)

#: What a failed attempt to reach a board raises: logged, then tried again.
RETRYABLE: tuple[type[BaseException], ...] = (
    ArduinoIOError,
    anyio.BrokenResourceError,
    anyio.ClosedResourceError,
)


@dataclass(frozen=True, slots=True)
class ManagerEvent:
    """A change: connected, disconnected, reset (restored), failsafe (re-armed), duplicate."""

    kind: Literal["connected", "disconnected", "reset", "failsafe", "duplicate"]
    board_id: int
    port: str
    detail: str = ""


class Events:
    """A board collection's news: listeners hear every event, waiters wake on every change.

    ``log`` is the owner's logger, so an event is logged under the module that owns the
    boards (``arduinoio_async.manager``, ``arduinoio_async.network._client``).
    """

    def __init__(self, log: logging.Logger) -> None:
        self._log = log
        self._listeners: list[Callable[[ManagerEvent], None]] = []
        self._changed = anyio.Event()

    def subscribe(self, callback: Callable[[ManagerEvent], None]) -> Callable[[], None]:
        """Call ``callback`` on every event; returns the call that unsubscribes it."""
        self._listeners.append(callback)
        return lambda: self._listeners.remove(callback)

    def wake(self) -> None:
        """Wake every waiter to look at the boards again."""
        changed, self._changed = self._changed, anyio.Event()
        changed.set()

    async def changed(self) -> None:
        """Wait for the next change (an event, an announcement, a board's restore)."""
        await self._changed.wait()

    def emit(self, event: ManagerEvent) -> None:
        """Log ``event``, wake the waiters and tell the listeners (a failing listener is
        logged: it must not stop the supervisor that emits)."""
        self._log.info(
            "board 0x%04X %s on %s%s",
            event.board_id,
            event.kind,
            event.port,
            f" ({event.detail})" if event.detail else "",
        )
        self.wake()
        for callback in list(self._listeners):
            try:
                callback(event)
            except Exception:
                self._log.exception("listener %r failed on %r", callback, event)


async def attach_board(
    boards: dict[int, Board],
    board_id: int,
    link: Transport,
    on_new: Callable[[Board], Awaitable[object]] | None = None,
) -> Board:
    """The ``Board`` of ``board_id`` on ``link``: made on first sight, else re-attached.

    Re-attaching keeps the caller's ``Board`` object and restores its pin roles, modes
    and failsafe on the new link (after a replug, a reset, or -- remotely -- a server
    restart); a new board is first handed to ``on_new`` (the manager sets its modes).
    """
    board = boards.get(board_id)
    if board is None:
        board = await Board.from_link(link)
        if on_new is not None:
            await on_new(board)
        boards[board_id] = board
    else:
        await board.adopt(link)
    return board


@dataclass(slots=True)
class LinkOutcome:
    """How one link's supervision ended (handed to ``on_end`` even when cancelled)."""

    #: The board attached (or known under the ID before), None if there was none.
    board: Board | None = None
    #: The board was attached and announced as connected.
    started: bool = False
    #: Why the link ended, in words ("" when cancelled while running).
    detail: str = ""
    #: The board answered under another ID after a reset: the link was given up.
    rekeyed: bool = False


#: Watches a running board; returning gives the link up, with the returned reason.
Watch = Callable[[Board], Awaitable[str]]


async def supervise_link(
    board_id: int,
    link: Transport,
    boards: dict[int, Board],
    events: Events,
    *,
    on_new: Callable[[Board], Awaitable[object]] | None = None,
    on_started: Callable[[], None] | None = None,
    on_end: Callable[[LinkOutcome], None] | None = None,
    watch: Watch | None = None,
) -> LinkOutcome:
    """Run ``link`` to board ``board_id``: attach and restore, heartbeat, detach at the end.

    ``on_started`` is called once the board is attached; ``on_end`` (always, before the
    "disconnected" event) with the outcome, for the caller's bookkeeping; ``watch`` runs
    beside the heartbeat and gives the link up when it returns.  A board or link failure
    ends the supervision with its text in ``detail``; it is never raised.
    """
    outcome = LinkOutcome(board=boards.get(board_id))
    closed = anyio.Event()
    link.on_state_change(lambda state: closed.set() if state is LinkState.CLOSED else None)
    try:
        async with link:
            board = outcome.board = await attach_board(boards, board_id, link, on_new)
            events.emit(ManagerEvent("connected", board_id, link.name))
            if on_started is not None:
                on_started()
            outcome.started = True
            given_up = await _heartbeat(board, link, closed, events, watch, outcome)
            outcome.detail = given_up or await _close_reason(link)
    except ArduinoIOError as exc:
        # The link failed mid-handshake or went away.
        outcome.detail = str(exc) or type(exc).__name__
    finally:
        if outcome.board is not None:
            outcome.board.detach(link)
        if on_end is not None:
            on_end(outcome)
        if outcome.board is not None:
            events.emit(
                ManagerEvent("disconnected", outcome.board.board_id, link.name, outcome.detail)
            )
    return outcome


async def _close_reason(link: Transport) -> str:
    """Why ``link`` closed: a request on a closed link fails with the close error."""
    try:
        await link.request(p.ReadStatus())
    except ArduinoIOError as exc:
        return str(exc) or type(exc).__name__
    return "the link closed"


async def _heartbeat(
    board: Board,
    link: Transport,
    closed: anyio.Event,
    events: Events,
    watch: Watch | None,
    outcome: LinkOutcome,
) -> str | None:
    """Keep the board's link alive; restore after a reset, re-arm after a failsafe trip.

    Returns why the link was given up (the board came back under another ID, or
    ``watch`` returned), else None once the link closed.
    """
    given_up: list[str] = []

    async def restore_after_reset() -> None:
        events.emit(ManagerEvent("reset", board.board_id, link.name, "restoring"))
        try:
            await board.adopt(link)
        except BoardIdChangedError as exc:
            logger.warning("%s", exc)
            given_up.append(str(exc))
            outcome.rekeyed = True
            await link.aclose()
            return
        events.wake()  # connected again: waiters for the board return

    async def rearm_after_trip() -> None:
        if board.failsafe is None:
            # Armed by someone else (a served client): nothing of ours to re-arm.  The
            # trip was logged once when noticed; the keepalive asks at every heartbeat.
            return
        events.emit(ManagerEvent("failsafe", board.board_id, link.name, "re-arming"))
        await board.rearm_failsafe(restore=True)

    async def watch_then_give_up(watch: Watch) -> None:
        given_up.append(await watch(board))
        closed.set()

    async with anyio.create_task_group() as tg:
        tg.start_soon(
            partial(board.keepalive, link, on_reset=restore_after_reset, on_trip=rearm_after_trip)
        )
        if watch is not None:
            tg.start_soon(watch_then_give_up, watch)
        await closed.wait()
        tg.cancel_scope.cancel()
    return given_up[0] if given_up else None


async def retry_forever(
    attempt: Callable[[], Awaitable[object]],
    *,
    pause: float,
    what: str,
    log: logging.Logger = logger,
    pause_first: bool = False,
) -> NoReturn:
    """Run ``attempt`` again and again, ``pause`` seconds apart, until cancelled.

    A failure to reach the board (:data:`RETRYABLE`) is logged and tried again; anything
    else is a bug and raised.  The pause is the loop's checkpoint: it runs after every
    attempt, failed or not, so a cancel always lands and a failing attempt never spins.
    """
    if pause_first:
        await anyio.sleep(pause)
    while True:
        try:
            await attempt()
        except RETRYABLE as exc:
            log.info("%s: %s", what, exc)
        await anyio.sleep(pause)
