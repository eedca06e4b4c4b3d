"""The board's watches: subscriptions the board keeps in RAM, recorded to restore them.

Change watches (``board.gpio(D3).watch()``), counter reports (``counter.reports(every=N)``),
analog deadband watches (``board.analog(A0).watch(deadband=N)``) and the stream
(``board.stream(...)``) are subscriptions the board holds in RAM: a reset (power loss,
watchdog, brown-out, ``board.reset()``) forgets them, as it forgets the pin roles.
:class:`Watches` is one board's record: one :class:`Subscription` per pin or channel (one
for the stream), shared by every block that asked for it (the last block to end stops it
on the board), with the request that made it.

When the board is restored after a reset (:meth:`Board.adopt
<arduinoio_async.board.Board.adopt>`, as the manager does on its own, or
:meth:`Board.restore <arduinoio_async.board.Board.restore>` / ``reset(restore=True)``), the
pin roles are replayed first, then :meth:`Watches.restore_on` sends each subscription's
request again, so the caller's ``async for`` goes on.  (Replaying a pin's set-up ends its
subscription on the board even without a reset, so every replay of the roles -- re-arming
the failsafe after a trip too -- is followed by the watches.)

* every queue is told first (:meth:`EventQueue.restart
  <arduinoio_async._event_queue.EventQueue.restart>`): its counts start afresh, as the
  board's sequence numbers do at boot, so the restart is not a gap of 65,000 events; its
  ``restarts`` counts the resets it lived through.  Events between the reset and the
  restore are unknown (the board was not watching) and in no count.
* a counter's replayed set-up starts its count at 0: its queue expects no particular
  next count (:meth:`EventQueue.resubscribing`);
* a subscription the board refuses (the pin has another role now, or none) ends each of
  its queues with :class:`~arduinoio_async.errors.WatchLostError`: the iterator raises it
  after the buffered items, and a callback watch logs it and raises it at its block's end.
* a link error goes to the restorer (the manager tries again at its next heartbeat); the
  subscriptions not restored yet stay pending.

A replug is no reset of a watch: its queue listened to the link that was lost and has
ended with :class:`~arduinoio_async.errors.BoardDisconnectedError`; the restore skips it.

One lock orders the starts, the last ends and the restore, so a block that ends (or is
cancelled) during a restore cannot leave the board watching a pin nobody follows.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import AsyncIterator, Callable, Hashable, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import anyio

from .. import protocol as p
from ..errors import ArduinoIOError, BoardError, UsageError, WatchLostError

if TYPE_CHECKING:
    from .._event_queue import EventQueue
    from ..transport import Transport

__all__ = ["Subscription", "Watches"]

logger = logging.getLogger(__name__)

R = TypeVar("R", bound=p.Reply)


class _Owner(Protocol):
    """What the record uses of its board (a part of
    :class:`~arduinoio_async.board._core.BoardCore`, which holds this record, so the record
    cannot name it)."""

    session: int

    @property
    def link(self) -> Transport: ...

    async def request(self, request: p.Request[R], *, timeout: float | None = None) -> R: ...


@dataclass(eq=False)
class Subscription:
    """One subscription on the board and the watch blocks that share it."""

    #: The request that subscribes (sent again after a reset).
    request: p.Request[Any]
    #: The request that ends the subscription on the board.
    stop: p.Request[Any]
    #: What the board must hold before ``request`` (a stream's I2C blocks), sent before it
    #: each time: a reset forgets them as it forgets the subscription.
    setup: tuple[p.Request[Any], ...] = ()
    queues: list[EventQueue[Any]] = field(default_factory=list)
    #: The link the board was last asked on (None: the board holds nothing to stop).
    link: Transport | None = None
    #: The board's session tag when it was last sent: another tag means a reset forgot it.
    session: int = 0


class Watches:
    """The subscriptions of one board, by key (``("gpio", 3)``, ``("analog", 0)``, ...)."""

    def __init__(self, board: _Owner) -> None:
        self._board = board
        self._subscriptions: dict[Hashable, Subscription] = {}
        self._lock = anyio.Lock()

    def __len__(self) -> int:
        return len(self._subscriptions)

    def requests(self) -> list[p.Request[Any]]:
        """The subscribing request of every current subscription (for tests, the monitor)."""
        return [sub.request for sub in self._subscriptions.values()]

    @asynccontextmanager
    async def subscribe(
        self,
        key: Hashable,
        request: p.Request[R],
        stop: p.Request[Any],
        queue: EventQueue[Any],
        conflict: Callable[[p.Request[Any]], str],
        setup: Sequence[p.Request[Any]] = (),
    ) -> AsyncIterator[R]:
        """Hold the subscription ``key`` for the block, feeding ``queue``; yields the reply.

        The request is sent for every block (the reply carries a fresh baseline), after
        ``setup`` when the block is the first to hold ``key``; a block whose ``request`` or
        ``setup`` differs from the one holding ``key`` is refused with :class:`UsageError`
        (``conflict(held)`` says why).  The last block to end sends ``stop``, shielded from
        cancellation.
        """
        sub = self._subscriptions.get(key)
        if sub is not None and (sub.request != request or sub.setup != tuple(setup)):
            queue.detach()
            raise UsageError(conflict(sub.request))
        first = sub is None
        if sub is None:
            sub = self._subscriptions[key] = Subscription(request, stop, tuple(setup))
        sub.queues.append(queue)
        try:
            async with self._lock:
                board = self._board
                link = board.link
                sub.link = link  # from here the board may hold it: the end stops it
                if first:
                    for step in sub.setup:
                        await board.request(step)
                reply = await board.request(request)
                sub.session = board.session
            yield reply
        finally:
            await self._end(key, sub, queue)

    async def _end(self, key: Hashable, sub: Subscription, queue: EventQueue[Any]) -> None:
        """``queue``'s block ended: the last one stops the board's subscription.

        Shielded, so a cancelled block still unsubscribes; a failure means the link is gone
        or the pin was reconfigured, and nothing is watched any more either way.
        """
        try:
            with anyio.CancelScope(shield=True):
                async with self._lock:
                    sub.queues.remove(queue)
                    if sub.queues or self._subscriptions.get(key) is not sub:
                        return
                    del self._subscriptions[key]
                    if sub.link is not None:
                        with contextlib.suppress(ArduinoIOError):
                            queue.stopped(await sub.link.request(sub.stop))
        finally:
            queue.detach()

    async def restore_on(self, link: Transport) -> None:
        """Subscribe every watch again, on ``link``, after the pin roles were replayed.

        After a reset the board forgot them all; without one, the replayed set-up of a
        pin (``board.restore()``, re-arming the failsafe) ended that pin's subscription
        on the board all the same.  See the module docstring for what the queues see.  A
        link error propagates with the rest still pending; a refusal ends that
        subscription's queues with WatchLostError.
        """
        session = self._board.session
        async with self._lock:
            subscriptions = list(self._subscriptions.items())
            # Every queue first: the board numbers events of all watched pins together, so
            # the first restored pin's events reach the others' queues too.
            for _key, sub in subscriptions:
                for queue in sub.queues:
                    if sub.session != session:
                        queue.restart(session, link)
                    queue.resubscribing()
            for key, sub in subscriptions:
                if all(queue.closed for queue in sub.queues):
                    sub.link, sub.session = None, session  # nobody follows it (link lost)
                    continue
                sub.link = link
                try:
                    for step in sub.setup:
                        await link.request(step)
                    reply = await link.request(sub.request)
                except BoardError as exc:
                    self._lose(key, sub, exc)
                    continue
                if sub.session != session:
                    logger.info("%r: %s restored after a reset", self._board, sub.request)
                sub.session = session
                for queue in sub.queues:
                    queue.restored(reply)

    def _lose(self, key: Hashable, sub: Subscription, refusal: BoardError) -> None:
        """The board refused ``sub`` after a reset: end its queues with WatchLostError."""
        del self._subscriptions[key]
        sub.link = None  # the board holds nothing: the blocks' ends send no stop
        error = WatchLostError(sub.request, str(refusal))
        error.__cause__ = refusal
        logger.error("%r: %s", self._board, error)
        for queue in sub.queues:
            queue.end(error)
