"""Board-initiated frames of one kind, buffered for one consumer (streams, change events).

Every kind of pushed data follows the same rules, so they are written once here: the
queue listens to the link's events from the moment it exists, keeps at most ``buffer``
items and drops the **oldest** when its consumer falls behind (counted in
:attr:`dropped`: the newest value is the one a controller needs), and ends iteration with
:class:`BoardDisconnectedError` once the link closes.  A subclass decides which events
are its own and what to count on them (sequence gaps, missed reports), then calls
:meth:`_put`.
"""

from __future__ import annotations

import collections
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Generic, TypeVar

import anyio

from . import protocol as p
from .errors import BoardDisconnectedError, ValueRangeError

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
        self._buffer: collections.deque[T] = collections.deque()
        self._arrived = anyio.Event()
        self._closed: BaseException | None = None
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
        if state.value == "closed":
            self._closed = BoardDisconnectedError(f"the link closed while watching {self.WHAT}")
            self._arrived.set()

    def __aiter__(self) -> EventQueue[T]:
        return self

    async def __anext__(self) -> T:
        while not self._buffer:
            if self._closed is not None:
                raise self._closed
            self._arrived = anyio.Event()
            await self._arrived.wait()
        return self._buffer.popleft()

    def pending(self) -> int:
        """Items buffered and not yet consumed."""
        return len(self._buffer)

    def detach(self) -> None:
        """Stop listening to the link (the consumer is done)."""
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
