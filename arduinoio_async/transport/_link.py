"""The request/response engine: one task reads the port, replies are matched in order.

Theory of operation
-------------------
``request()`` registers a pending entry *before* the frame is written (under a send lock,
so the order of the pending queue is the order on the wire) and then waits for it.  The
reader task is the only consumer of the port: it feeds every chunk to the sans-IO
:class:`~arduinoio_async.protocol.Decoder` and pops the head of the pending queue for each
reply.  A reply is delivered only if it *matches* the head (type and every echoed field);
an error reply only if it names the head's tags.  Board-initiated frames (class 0x40) never
touch the queue; they go to subscribers.

Anything that breaks the in-order correspondence -- garbage, a framing error reply from the
board, a reply that does not match, a reply nobody asked for, a timeout -- makes the link
*lose sync*: every pending request fails at once with a precise exception (its fate on the
board is unknown), new requests wait, and the reader drains the line until it has been
quiet for ``quiet_time`` (longer than the board's 10 ms inter-byte gap, so the board is
ready for a frame again), discards what it buffered, confirms the board with an ID
request, and carries on.  No reply is ever handed to a caller it was not verified for.

A caller that is cancelled leaves its pending entry in the queue marked *abandoned*: the
reply is still consumed in order, then dropped, so cancellation never desynchronises the
link.  Losing the port fails every pending and every later request with
:class:`BoardDisconnectedError` at once.

Sends are not done by the reader task: handing each request to another task would cost a
task switch per request.  The send lock gives the same guarantee -- one writer at a time,
pending order equals wire order -- and the send is shielded so a cancellation cannot cut a
frame in half.
"""

from __future__ import annotations

import asyncio
import collections
import time
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from enum import Enum
from typing import Any, Literal, TypeVar

import anyio
import anyio.abc

from .. import protocol as p
from ..errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    BoardTimeoutError,
    FailsafeTrippedError,
    I2CError,
    LinkCapacityError,
    LinkError,
    LinkResyncError,
    ReplyMismatchError,
)

__all__ = [
    "DEFAULT_TIMEOUT",
    "QUIET_TIME",
    "LinkState",
    "LinkStats",
    "TraceHook",
    "TraceRecord",
    "Transport",
    "board_error",
]

#: Default time a request may take, queueing included.  Generous against a real Uno whose
#: USB bridge adds up to 4 ms per reply and whose I2C or EEPROM commands take milliseconds.
DEFAULT_TIMEOUT = 0.5
#: Silence that proves the line is drained: the board's 10 ms inter-byte gap, plus a 4 ms
#: USB-bridge tick and a USB frame, with margin.
QUIET_TIME = 0.03
#: Longest drain before probing anyway (a running stream never lets the line go quiet).
MAX_DRAIN = 0.25
#: Requests in flight at once, whatever their size.
MAX_IN_FLIGHT = 64

R = TypeVar("R", bound=p.Reply)


class LinkState(Enum):
    READY = "ready"
    RESYNCING = "resyncing"
    CLOSED = "closed"


@dataclass(frozen=True, slots=True)
class TraceRecord:
    """One frame (or garbage run) crossing the link; ``time_ns`` is ``perf_counter_ns``."""

    time_ns: int
    direction: Literal["tx", "rx"]
    item: p.Frame | p.Garbage


TraceHook = Callable[[TraceRecord], None]


@dataclass(slots=True)
class LinkStats:
    """Counters for diagnostics and benchmarks."""

    requests: int = 0
    replies: int = 0
    events: int = 0
    timeouts: int = 0
    resyncs: int = 0
    garbage_bytes: int = 0
    dropped_late_replies: int = 0


_ERROR_CLASSES: dict[p.ErrorCode, type[BoardError]] = {
    p.ErrorCode.I2C_NACK_ADDRESS: I2CError,
    p.ErrorCode.I2C_NACK_DATA: I2CError,
    p.ErrorCode.I2C_TIMEOUT: I2CError,
    p.ErrorCode.I2C_NOT_CONFIGURED: I2CError,
    p.ErrorCode.LINK_CAPACITY: LinkCapacityError,
    p.ErrorCode.FAILSAFE_TRIPPED: FailsafeTrippedError,
}


def board_error(reply: p.ErrorReply, request: p.Request[Any]) -> BoardError:
    """The exception for an error reply to ``request``."""
    cls = _ERROR_CLASSES.get(reply.code, BoardError)
    return cls(reply.code, request)


class _Pending:
    """One request in flight.  On asyncio it waits on a bare future with a ``call_at``
    timer (a cancel scope and an Event per request cost more than the rest of the
    request together); on other backends on an anyio Event in a cancel scope."""

    __slots__ = (
        "_event",
        "_future",
        "_timer",
        "abandoned",
        "done",
        "error",
        "reply",
        "request",
        "size",
    )

    def __init__(
        self, request: p.Request[Any], size: int, loop: asyncio.AbstractEventLoop | None
    ) -> None:
        self.request = request
        self.size = size
        self.reply: p.Reply | None = None
        self.error: ArduinoIOError | None = None
        self.done = False
        self.abandoned = False
        self._timer: asyncio.TimerHandle | None = None
        self._future: asyncio.Future[None] | None = None
        self._event: anyio.Event | None = None
        if loop is not None:
            self._future = loop.create_future()
        else:
            self._event = anyio.Event()

    def resolve(self, reply: p.Reply | None, error: ArduinoIOError | None) -> None:
        if self.done:
            return
        self.reply = reply
        self.error = error
        self.done = True
        if self._timer is not None:
            self._timer.cancel()
        if self._future is not None:
            if not self._future.done():
                self._future.set_result(None)
        elif self._event is not None:
            self._event.set()

    async def wait(self, deadline: float, expire: Callable[[_Pending], None]) -> None:
        """Until resolved; at ``deadline`` call ``expire`` (which resolves it)."""
        if self.done:
            return
        if self._future is not None:
            self._timer = self._future.get_loop().call_at(deadline, expire, self)
            await self._future
            return
        assert self._event is not None
        with anyio.move_on_after(deadline - anyio.current_time()):
            await self._event.wait()
        if not self.done:
            expire(self)


class Transport:
    """Owns one byte stream to one board; use as an async context manager."""

    def __init__(
        self,
        stream: anyio.abc.ByteStream,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        window_bytes: int = p.RX_FIFO_SIZE,
        quiet_time: float = QUIET_TIME,
        trace: TraceHook | None = None,
        name: str = "",
    ) -> None:
        self.stream = stream
        self.timeout = timeout
        self.window_bytes = window_bytes
        self.quiet_time = quiet_time
        self.trace = trace
        self.name = name or getattr(stream, "port", "") or "link"
        #: Board ID a resync must find; set once the board is known.
        self.expected_id: int | None = None
        self.stats = LinkStats()
        self._decoder = p.Decoder.from_board()
        self._pending: collections.deque[_Pending] = collections.deque()
        self._inflight_bytes = 0
        self._state = LinkState.READY
        self._close_error: BoardDisconnectedError | None = None
        self._changed = anyio.Event()
        self._send_lock = anyio.Lock()
        self._receive_scope: anyio.CancelScope | None = None
        #: Why the link last lost sync (for diagnostics), or None.
        self.last_loss: str | None = None
        self._subscribers: list[Callable[[p.Event], None]] = []
        self._state_listeners: list[Callable[[LinkState], None]] = []
        self._task_group: anyio.abc.TaskGroup | None = None
        self._waiters = 0
        #: ``anyio.current_time()`` of the last request sent (heartbeats skip busy links).
        self.last_send = 0.0
        #: Streams that can write without suspending get the fast path (no lock needed).
        self._send_nowait: Callable[[bytes], None] | None = getattr(stream, "send_nowait", None)
        self._loop: asyncio.AbstractEventLoop | None = None

    # ---- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> Transport:
        try:  # running on anyio's asyncio backend?
            self._loop = asyncio.get_running_loop()
        except RuntimeError:
            self._loop = None
        self._task_group = anyio.create_task_group()
        await self._task_group.__aenter__()
        self._task_group.start_soon(self._reader, name=f"arduinoio reader {self.name}")
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.aclose()
        if self._task_group is not None:
            self._task_group.cancel_scope.cancel()
            group, self._task_group = self._task_group, None
            await group.__aexit__(None, None, None)

    async def aclose(self) -> None:
        """Close the port; pending and later requests fail with BoardDisconnectedError.

        Safe to call from any task; the reader task ends by itself.
        """
        self._mark_closed(BoardDisconnectedError(f"{self.name}: link closed"))
        with anyio.CancelScope(shield=True):
            await self.stream.aclose()

    def start_background(
        self, func: Callable[..., Coroutine[Any, Any, Any]], *args: Any, name: str | None = None
    ) -> None:
        """Run ``func(*args)`` alongside the reader; it is cancelled when the link closes."""
        if self._task_group is None:
            raise RuntimeError("the transport is not running (use it as a context manager)")
        self._task_group.start_soon(func, *args, name=name)

    @property
    def state(self) -> LinkState:
        return self._state

    @property
    def in_flight(self) -> int:
        """Requests sent and not yet answered."""
        return len(self._pending)

    @property
    def in_flight_bytes(self) -> int:
        """Request bytes sent and not yet answered (bounded by ``window_bytes``)."""
        return self._inflight_bytes

    def subscribe(self, callback: Callable[[p.Event], None]) -> Callable[[], None]:
        """Call ``callback`` (in the reader task) for each board-initiated frame."""
        self._subscribers.append(callback)
        return lambda: self._subscribers.remove(callback)

    def on_state_change(self, callback: Callable[[LinkState], None]) -> Callable[[], None]:
        """Call ``callback`` whenever the link becomes ready, resyncs or closes."""
        self._state_listeners.append(callback)
        return lambda: self._state_listeners.remove(callback)

    # ---- requests ----------------------------------------------------------------------

    async def request(self, request: p.Request[R], *, timeout: float | None = None) -> R:
        """Send ``request`` and return its verified reply.

        Raises :class:`BoardError` (or a subclass) for an error reply,
        :class:`BoardTimeoutError`, :class:`LinkResyncError`, or
        :class:`BoardDisconnectedError`.
        """
        frame = request.encode()
        limit = self.timeout if timeout is None else timeout
        deadline = anyio.current_time() + limit
        pending = self._send_now(request, frame)
        if pending is None:
            pending = await self._enqueue(request, frame, deadline, limit)
        try:
            await pending.wait(deadline, self._expire)
        finally:
            if not pending.done:
                pending.abandoned = True
        if pending.error is not None:
            raise pending.error
        return pending.reply  # type: ignore[return-value]

    def _expire(self, pending: _Pending) -> None:
        """A request's deadline passed without its reply: the link has lost sync."""
        if pending.done:
            return
        self.stats.timeouts += 1
        limit = self.timeout
        error = BoardTimeoutError(
            f"{self.name}: no reply to {type(pending.request).__name__} in time "
            f"(default timeout {limit:g} s)"
        )
        self._lose_sync(f"{type(pending.request).__name__} timed out", blame=pending, error=error)
        pending.resolve(None, error)

    def _must_wait(self, size: int) -> bool:
        return (
            self._state is not LinkState.READY
            or len(self._pending) >= MAX_IN_FLIGHT
            or (bool(self._pending) and self._inflight_bytes + size > self.window_bytes)
        )

    def _register(self, request: p.Request[Any], size: int) -> _Pending:
        pending = _Pending(request, size, self._loop)
        self._pending.append(pending)
        self._inflight_bytes += size
        self.stats.requests += 1
        self.last_send = anyio.current_time()
        return pending

    def _sent(self, request: p.Request[Any]) -> None:
        if self.trace is not None:
            self.trace(TraceRecord(time.perf_counter_ns(), "tx", request))

    def _send_now(self, request: p.Request[Any], frame: bytes) -> _Pending | None:
        """The fast path: register and write without a suspension point, or None."""
        send_nowait = self._send_nowait
        if send_nowait is None or self._send_lock.locked() or self._must_wait(len(frame)):
            return None
        pending = self._register(request, len(frame))
        try:
            send_nowait(frame)
        except (anyio.BrokenResourceError, anyio.ClosedResourceError, OSError) as exc:
            self._mark_closed(BoardDisconnectedError(f"{self.name}: write failed: {exc}"))
        self._sent(request)
        return pending

    async def _enqueue(
        self, request: p.Request[Any], frame: bytes, deadline: float, limit: float
    ) -> _Pending:
        """The slow path: wait for the link and the window, then send under the lock."""
        size = len(frame)
        while True:
            while self._must_wait(size):
                if self._close_error is not None:
                    raise BoardDisconnectedError(str(self._close_error))
                changed = self._changed
                self._waiters += 1
                try:
                    with anyio.move_on_after(deadline - anyio.current_time()):
                        await changed.wait()
                finally:
                    self._waiters -= 1
                if anyio.current_time() >= deadline and not changed.is_set():
                    self.stats.timeouts += 1
                    raise BoardTimeoutError(
                        f"{self.name}: {type(request).__name__} waited {limit:g} s for the "
                        f"link ({self._state.value}, {len(self._pending)} in flight)"
                    )
            async with self._send_lock:
                # Other requests may have taken the window while this one took the lock.
                if self._must_wait(size):
                    continue
                pending = self._register(request, size)
                with anyio.CancelScope(shield=True):
                    try:
                        await self.stream.send(frame)
                    except (anyio.BrokenResourceError, anyio.ClosedResourceError, OSError) as exc:
                        self._mark_closed(
                            BoardDisconnectedError(f"{self.name}: write failed: {exc}")
                        )
                self._sent(request)
                return pending

    # ---- the reader task ---------------------------------------------------------------

    async def _reader(self) -> None:
        try:
            while self._state is not LinkState.CLOSED:
                if self._state is LinkState.RESYNCING:
                    await self._resync()
                    continue
                # One cancel scope per stretch of good operation, not one per chunk:
                # _lose_sync() cancels it to wake a reader blocked on a silent line.
                with anyio.CancelScope() as scope:
                    self._receive_scope = scope
                    while self._state is LinkState.READY:
                        self._handle(await self.stream.receive())
                self._receive_scope = None
        except (anyio.EndOfStream, anyio.BrokenResourceError, anyio.ClosedResourceError) as exc:
            self._mark_closed(BoardDisconnectedError(f"{self.name}: port lost ({exc or 'EOF'})"))
        except OSError as exc:
            self._mark_closed(BoardDisconnectedError(f"{self.name}: port error: {exc}"))

    def _handle(self, data: bytes) -> None:
        trace = self.trace
        for item in self._decoder.feed(data):
            if trace is not None:
                trace(TraceRecord(time.perf_counter_ns(), "rx", item))
            if self._state is not LinkState.READY:
                if isinstance(item, p.Event):
                    self._publish(item)
                continue
            self._dispatch(item)

    def _dispatch(self, item: p.Decoded) -> None:
        if isinstance(item, p.Reply):
            head = self._pending[0] if self._pending else None
            if head is None:
                self._lose_sync(f"unsolicited {type(item).__name__}")
            elif head.request.matches(item):
                self._complete(head, item, None)
            else:
                error = ReplyMismatchError(
                    f"{self.name}: {type(item).__name__} does not answer "
                    f"{head.request!r} (got {item!r})"
                )
                self._lose_sync("reply mismatch", blame=head, error=error)
        elif isinstance(item, p.Event):
            self._publish(item)
        elif isinstance(item, p.ErrorReply):
            head = self._pending[0] if self._pending else None
            if item.framing:
                self._lose_sync(f"board reported {item.code.name}")
            elif head is not None and item.answers(head.request):
                self._complete(head, None, board_error(item, head.request))
            else:
                self._lose_sync(f"error reply {item.code.name} does not answer the request")
        elif isinstance(item, p.Garbage):
            self.stats.garbage_bytes += len(item.data)
            self._lose_sync(f"{len(item.data)} garbage bytes")

    def _complete(self, pending: _Pending, reply: p.Reply | None, error: Any) -> None:
        self._pending.popleft()
        self._inflight_bytes -= pending.size
        self.stats.replies += 1
        if pending.abandoned:
            self.stats.dropped_late_replies += 1
        pending.resolve(reply, error)
        self._notify()

    def _publish(self, event: p.Event) -> None:
        self.stats.events += 1
        for callback in list(self._subscribers):
            callback(event)

    # ---- losing and regaining sync -----------------------------------------------------

    def _lose_sync(
        self, reason: str, *, blame: _Pending | None = None, error: LinkError | None = None
    ) -> None:
        """Fail everything in flight and make the reader resynchronise."""
        if self._state is not LinkState.READY:
            return
        self.last_loss = reason
        self._fail_pending(
            lambda pending: (
                error
                if pending is blame and error is not None
                else LinkResyncError(f"{self.name}: link lost sync ({reason}); request aborted")
            )
        )
        self._set_state(LinkState.RESYNCING)
        if self._receive_scope is not None:
            self._receive_scope.cancel()

    def _fail_pending(self, make_error: Callable[[_Pending], ArduinoIOError]) -> None:
        pending, self._pending = self._pending, collections.deque()
        self._inflight_bytes = 0
        for entry in pending:
            entry.resolve(None, make_error(entry))

    async def _resync(self) -> None:
        delay = self.quiet_time
        while self._state is LinkState.RESYNCING:
            await self._drain()
            self._decoder.reset()
            found = await self._probe()
            if found is None:
                await anyio.sleep(delay)
                delay = min(delay * 2, 1.0)
                continue
            if self.expected_id is not None and found != self.expected_id:
                self._mark_closed(
                    BoardDisconnectedError(
                        f"{self.name}: board 0x{self.expected_id:04X} was replaced by a "
                        f"board with ID 0x{found:04X}"
                    )
                )
                return
            self.stats.resyncs += 1
            self._set_state(LinkState.READY)

    async def _drain(self) -> None:
        """Read and discard until the line is quiet (or MAX_DRAIN passes)."""
        give_up = anyio.current_time() + MAX_DRAIN
        while anyio.current_time() < give_up:
            with anyio.move_on_after(self.quiet_time):
                data = await self.stream.receive()
                for item in self._decoder.feed(data):
                    if isinstance(item, p.Event):
                        self._publish(item)
                continue
            return

    async def _probe(self) -> int | None:
        """Send an ID request and return the ID, or None if no valid answer came."""
        async with self._send_lock:
            await self.stream.send(p.ReadId().encode())
        with anyio.move_on_after(self.timeout):
            while True:
                data = await self.stream.receive()
                for item in self._decoder.feed(data):
                    if isinstance(item, p.ReadIdReply):
                        return item.board_id
                    if isinstance(item, p.Event):
                        self._publish(item)
        return None

    def _mark_closed(self, error: BoardDisconnectedError) -> None:
        if self._state is LinkState.CLOSED:
            return
        self._close_error = error
        self._fail_pending(lambda _pending: BoardDisconnectedError(str(error)))
        self._set_state(LinkState.CLOSED)
        if self._receive_scope is not None:
            self._receive_scope.cancel()

    def _set_state(self, state: LinkState) -> None:
        self._state = state
        self._notify()
        for callback in list(self._state_listeners):
            callback(state)

    def _notify(self) -> None:
        if self._waiters:
            changed, self._changed = self._changed, anyio.Event()
            changed.set()
