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
from typing import TYPE_CHECKING, Generic, TypeVar

import anyio

from . import protocol as p
from .errors import BoardDisconnectedError, ValueRangeError

if TYPE_CHECKING:
    from .transport import LinkState, Transport

__all__ = ["EventQueue"]

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
