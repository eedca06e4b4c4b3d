"""Board-initiated frames of one kind, buffered for one consumer (streams, change events).

Every kind of pushed data follows the same rules, so they are written once here: the
queue listens to the link's events from the moment it exists, keeps at most ``buffer``
items and drops the **oldest** when its consumer falls behind (counted in
:attr:`dropped`: the newest value is the one a controller needs), and ends iteration with
:class:`BoardDisconnectedError` once the link closes.  A subclass decides which events
are its own and what to count on them (sequence gaps, missed reports), then calls
:meth:`_put`.

A watch's queue outlives a reset of the board (:mod:`arduinoio_async.board.watches`
subscribes it again): :meth:`EventQueue.restart` starts its counts afresh, as the board's
numbering does at boot, and :attr:`EventQueue.restarts` counts the resets it lived
through; a watch that could not be restored ends with :meth:`EventQueue.end`.
"""

from __future__ import annotations

import collections
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Generic, TypeVar

import anyio

from . import protocol as p
from .errors import BoardDisconnectedError, LinkError, ValueRangeError

if TYPE_CHECKING:
    from .transport import LinkState, Transport

__all__ = ["EventQueue", "SequencedQueue"]

logger = logging.getLogger(__name__)

T = TypeVar("T")


class EventQueue(Generic[T]):
    """Async iterator over the items a subclass takes from the link's events."""

    #: What the consumer watches, for error messages ("a stream", "changes", ...).
    WHAT = "events"

    def __init__(self, link: Transport, buffer: int) -> None:
        if buffer < 1:
            raise ValueRangeError(f"{self.WHAT} buffer", buffer, "1 and up")
        self.buffer_size = buffer
        self.received = 0
        self.dropped = 0
        #: Resets of the board this queue's watch was restored through.  The events of
        #: the time between a reset and the restore are unknown and in no other count:
        #: the board was not watching.
        self.restarts = 0
        self._restart_session: int | None = None
        self._buffer: collections.deque[T] = collections.deque()
        self._arrived = anyio.Event()
        self._closed: BaseException | None = None
        self._raised = False  # whether __anext__ has raised _closed to the consumer
        self._link = link
        self._detached = False
        self._unsubscribe = link.subscribe(self._on_event)
        self._stop_state = link.on_state_change(self._on_state)

    def _on_event(self, event: p.Event) -> None:
        raise NotImplementedError

    def _put(self, item: T) -> None:
        self.received += 1
        if len(self._buffer) >= self.buffer_size:
            self._buffer.popleft()
            self.dropped += 1
        self._buffer.append(item)
        self._arrived.set()

    def _on_state(self, state: LinkState) -> None:
        if state.value == "closed" and self._closed is None:
            self._closed = BoardDisconnectedError(f"the link closed while watching {self.WHAT}")
            self._arrived.set()

    @property
    def closed(self) -> bool:
        """True once iteration will end (after the buffered items): link lost or watch lost."""
        return self._closed is not None

    def end(self, error: BaseException) -> None:
        """End iteration with ``error`` once the buffered items are consumed; stop listening."""
        if self._closed is None:
            self._closed = error
        self._arrived.set()
        self.detach()

    def raise_unreported(self) -> None:
        """Raise the error :meth:`end` gave, unless iteration raised it already.

        For the end of a watch block: a callback watch never iterates, and its block is
        where the caller learns that the watch was lost.
        """
        closed = self._closed
        if closed is not None and not self._raised and not isinstance(closed, LinkError):
            self._raised = True
            raise closed

    def restart(self, session: int, link: Transport) -> None:
        """The board reset (its new boot is tagged ``session``) and the watch is being
        subscribed again on ``link``: counts start afresh, as the board's do at boot.

        Called once per boot however often a failing restore is retried.
        """
        if self._restart_session == session:
            return
        self._restart_session = session
        self.restarts += 1
        if link is not self._link and not self._detached and self._closed is None:
            self.detach()
            self._detached = False
            self._link = link
            self._unsubscribe = link.subscribe(self._on_event)
            self._stop_state = link.on_state_change(self._on_state)

    def resubscribing(self) -> None:
        """The watch is about to be subscribed again (after a reset or a replayed set-up)."""

    def restored(self, reply: p.Reply) -> None:
        """The board accepted the watch again with ``reply`` (a subclass may read it)."""

    def stopped(self, reply: p.Reply) -> None:
        """The board ended the subscription with ``reply`` (a subclass may read it)."""

    def __aiter__(self) -> EventQueue[T]:
        return self

    async def __anext__(self) -> T:
        while not self._buffer:
            if self._closed is not None:
                self._raised = True
                raise self._closed
            self._arrived = anyio.Event()
            await self._arrived.wait()
        return self._buffer.popleft()

    def pending(self) -> int:
        """Items buffered and not yet consumed."""
        return len(self._buffer)

    def detach(self) -> None:
        """Stop listening to the link (the consumer is done); once is enough."""
        if self._detached:
            return
        self._detached = True
        self._unsubscribe()
        self._stop_state()


class SequencedQueue(EventQueue[T]):
    """An :class:`EventQueue` of numbered frames (stream samples, change events).

    The board numbers each kind of event with a 16-bit sequence; a number that jumps
    counts the frames the board dropped or the line lost in :attr:`gaps`.  With
    ``callback`` the items go to it on the link's reader instead of the buffer; an
    exception in it is logged and never reaches the link.
    """

    def __init__(
        self, link: Transport, buffer: int, callback: Callable[[T], None] | None = None
    ) -> None:
        self.gaps = 0
        self._expected: int | None = None
        self._callback = callback
        super().__init__(link, buffer)

    @property
    def lost(self) -> int:
        """Items that never reached the consumer: sequence gaps plus buffer overflow."""
        return self.gaps + self.dropped

    def restart(self, session: int, link: Transport) -> None:
        """After a reset the board numbers from 0 again: the next number is no gap."""
        super().restart(session, link)
        self._expected = None

    def _count_gap(self, sequence: int) -> None:
        if self._expected is not None and sequence != self._expected:
            self.gaps += (sequence - self._expected) & 0xFFFF
        self._expected = (sequence + 1) & 0xFFFF

    def _deliver(self, item: T) -> None:
        if self._callback is None:
            self._put(item)
            return
        self.received += 1
        try:
            self._callback(item)
        except Exception:  # a user's bug must not hurt the link
            logger.exception("%s callback %r failed on %r", self.WHAT, self._callback, item)
