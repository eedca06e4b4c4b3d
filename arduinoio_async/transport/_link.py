"""The request/response engine: a thin I/O shell around the sans-IO link session.

Theory of operation
-------------------
Every rule about order, matching and failure lives in
:class:`~arduinoio_async.protocol.session.Session`; this module only moves bytes, keeps
time and wakes callers.  ``request()`` hands the request to the session, which queues it
in one FIFO and returns the bytes that may go on the wire now; they are written at once,
without a suspension point, so the order of calls is the order on the wire whatever the
number of tasks.  A request that does not fit the board's receive window waits in the
session's queue and is written by whoever frees the window (the code that handles
received bytes), in call order: no waiter races for the window, and a queued request
always gets its turn.

Received bytes go to the session as they arrive.  On asyncio, with a stream that can push
(the serial stream), that happens in the event loop's fd-readable callback: the reply is
decoded and matched there and the waiting caller's future resolved, so a round trip costs
one loop iteration and no task switch.  The common case -- one request in flight, its reply
alone in a chunk -- takes :meth:`Session.receive_reply`, which allocates nothing.  When one
chunk completes several requests (pipelining), the stream is asked to collect what the
woken callers send next into one write, at the end of the same loop iteration in which
they send it (``SerialByteStream.collect_sends``): still one byte stream in call order, one
syscall instead of one per request.  Other streams and backends (trio) use a reader task
with anyio's portable primitives.

*The per-request timeout* covers the whole call: waiting in the queue (behind a window
full of earlier requests, or a resync), the flight, and transparent retries.  A request
that expires before it was sent fails with :class:`BoardTimeoutError` and costs nothing
else; one that expires in flight means the board did not answer, and the link resyncs.  On
asyncio each exchange carries its deadline and one alarm per link
(:class:`~arduinoio_async.transport._deadline.DeadlineAlarm`) is armed for the earliest:
re-armed only when it rings or for an earlier deadline, and kept off the event loop's timer
heap, whose cost every loop iteration would pay.  On trio each request waits in its own
cancel scope.

When the session loses sync, the resync task drains the line and probes until the board
answers in frames again (:mod:`._resync` says when the line counts as drained).

A caller that is cancelled leaves its request in place (if sent): the reply is consumed in
order, then dropped, so cancellation never desynchronises the link.  Losing the port fails
every pending and every later request with :class:`BoardDisconnectedError` at once.
Subscribers (stream consumers, failsafe listeners) run in the receive path; an exception
in one is logged and never reaches the link.

*Requests from other threads.*  A server receives requests on its network library's
threads; handing each to the loop before it can go on the wire costs a thread wake-up per
round trip.  :meth:`Transport.request_from_thread` puts a request into the session and
on the wire from the calling thread instead, with a callback the loop runs when the
request is done.  One lock -- the serial stream's, held by every loop callback that
changes what goes on the wire -- makes the session's order the wire's order whichever
thread sends: the loop holds it from ``session.send`` until the bytes are written or
queued and the caller's waiter and deadline are set, and while it handles received
bytes, expires requests or resyncs.  The other thread never waits for it: if the loop
holds it, the request goes through the loop after all.
"""

from __future__ import annotations

import asyncio
import logging
import math
import threading
import time
from collections.abc import Callable, Coroutine
from contextlib import AsyncExitStack, suppress
from typing import Any, TypeVar

import anyio
import anyio.abc
import anyio.lowlevel

from .. import protocol as p
from ..errors import BoardDisconnectedError
from ..protocol.session import (
    MAX_IN_FLIGHT,
    Exchange,
    LinkStats,
    Session,
    SessionState,
    board_error,
)
from ._deadline import DeadlineAlarm
from ._link_types import (
    DEFAULT_TIMEOUT,
    FRAMING_ENV,
    QUIET_TIME,
    LinkState,
    TraceHook,
    TraceRecord,
    default_framing,
)
from ._resync import Resyncing
from ._streams import abilities_of
from ._wire import WRITE_ERRORS

__all__ = [
    "DEFAULT_TIMEOUT",
    "FRAMING_ENV",
    "MAX_IN_FLIGHT",
    "QUIET_TIME",
    "LinkState",
    "LinkStats",
    "TraceHook",
    "TraceRecord",
    "Transport",
    "board_error",
    "default_framing",
]

logger = logging.getLogger(__name__)

R = TypeVar("R", bound=p.Reply)


class Transport(Resyncing):
    """Owns one byte stream to one board; use as an async context manager.

    The requests, the deadlines and the lifecycle are here; the bytes in and out and what
    they wake in :class:`~._wire.Wire`, regaining sync in :class:`~._resync.Resyncing`.
    """

    def __init__(
        self,
        stream: anyio.abc.ByteStream,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        window_bytes: int = p.RX_FIFO_SIZE,
        quiet_time: float = QUIET_TIME,
        trace: TraceHook | None = None,
        name: str = "",
        framing: p.Framing | None = None,
    ) -> None:
        self.stream = stream
        self.timeout = timeout
        self.quiet_time = quiet_time
        #: The longest the resync may leave the line silent while it waits for a probe's
        #: answer or backs off (None: no limit).  A board whose failsafe is armed must
        #: hear a frame well within its timeout, and a probe's lost answer would otherwise
        #: silence the host for the whole ``timeout``; the keepalive sets it.
        self.max_silence: float | None = None
        #: What the stream declared it can do, looked at once (see ``_streams.py``).
        self.abilities = abilities = abilities_of(stream)
        self.name = name or abilities.port or "link"
        # The negotiation step: the session switches the link to ``framing`` as soon as
        # the board's capabilities (the first thing a Board reads) say it can, and again
        # after the board resets (see protocol/_framing.py).  A stream that relays
        # another link (the network client's: ``relay_failures_to``) has no wire of its
        # own to protect: its far end decodes the paper's frames and checks its own wire.
        if framing is None:
            framing = p.Framing.XOR if abilities.relays else default_framing()
        self._session = Session(
            window_bytes=window_bytes,
            max_in_flight=MAX_IN_FLIGHT,
            name=self.name,
            framing=framing,
        )
        self._trace: TraceHook | None = None
        self.trace = trace
        self._subscribers: list[Callable[[p.Event], None]] = []
        self._state_listeners: list[Callable[[LinkState], None]] = []
        self._state = LinkState.READY
        self._exit_stack: AsyncExitStack | None = None
        self._task_group: anyio.abc.TaskGroup | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._send_nowait: Callable[[bytes], None] | None = None
        self._collect_sends: Callable[[], None] | None = None
        #: Orders the session and the wire between the loop and other threads (see
        #: ``request_from_thread``): the stream's own lock where it has one.
        thread_sender = abilities.thread_sender
        self._lock: Any = thread_sender.lock if thread_sender is not None else threading.RLock()
        self._send_from_thread: Callable[[bytes], bool] | None = None
        self._outbox = bytearray()
        self._outbox_ready = anyio.Event()
        #: Monotonic time of the last request sent (heartbeats skip busy links).
        self.last_send = 0.0
        self._last_rx = 0.0
        self._rx_since_loss = False
        self._lost_at = 0.0
        self._changed = anyio.Event()
        self._watchers = 0
        self._session_state = SessionState.READY
        self._resync_needed = anyio.Event()
        #: The deadline alarm (asyncio; trio waits with a cancel scope per request).
        self._alarm: DeadlineAlarm | None = None
        self._now: Callable[[], float] = anyio.current_time
        #: Callers inside :meth:`expecting_reboot` (nested ones count).
        self._reboots = 0

    # ---- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> Transport:
        try:  # on anyio's asyncio backend (or uvloop)?
            self._loop = asyncio.get_running_loop()
            # The alarm's clock; the default loop's own ``time()`` is this one behind a
            # Python call.
            self._now = time.monotonic
            self._alarm = DeadlineAlarm(self._loop, self._on_alarm)
        except RuntimeError:
            self._loop = None
            self._now = anyio.current_time
        stack = AsyncExitStack()
        try:
            self._task_group = await stack.enter_async_context(anyio.create_task_group())
            abilities = self.abilities
            push = abilities.push
            pushed = push is not None and push.attach(self._on_data, self._on_lost)
            if not pushed:
                self._task_group.start_soon(self._reader, name=f"arduinoio reader {self.name}")
            self._send_nowait = abilities.send_nowait
            self._collect_sends = abilities.collect_sends
            if pushed and self._loop is not None and abilities.thread_sender is not None:
                self._send_from_thread = abilities.thread_sender.send_from_thread
            if self._send_nowait is None:
                self._task_group.start_soon(self._writer, name=f"arduinoio writer {self.name}")
            self._task_group.start_soon(self._resyncer, name=f"arduinoio resync {self.name}")
        except BaseException:
            await stack.aclose()
            raise
        self._exit_stack = stack
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.aclose()
        stack, self._exit_stack = self._exit_stack, None
        if stack is not None:
            assert self._task_group is not None
            self._task_group.cancel_scope.cancel()
            self._task_group = None
            await stack.aclose()

    async def aclose(self) -> None:
        """Close the port; pending and later requests fail with BoardDisconnectedError.

        Safe to call from any task.
        """
        self._close(BoardDisconnectedError(f"{self.name}: link closed"))
        with anyio.CancelScope(shield=True):
            with suppress(OSError, anyio.BrokenResourceError, anyio.ClosedResourceError):
                await self.stream.aclose()

    def start_background(
        self, func: Callable[..., Coroutine[Any, Any, Any]], *args: Any, name: str | None = None
    ) -> None:
        """Run ``func(*args)`` alongside the link; it is cancelled when the link closes."""
        if self._task_group is None:
            raise RuntimeError("the transport is not running (use it as a context manager)")
        self._task_group.start_soon(func, *args, name=name)

    # ---- properties --------------------------------------------------------------------

    @property
    def state(self) -> LinkState:
        return self._state

    @property
    def stats(self) -> LinkStats:
        return self._session.stats

    @property
    def last_loss(self) -> str | None:
        """Why the link last lost sync (for diagnostics), or None."""
        return self._session.last_loss

    @property
    def expected_id(self) -> int | None:
        """Board ID a resync must find (None: any); follows a WriteId's reply or probe."""
        return self._session.expected_id

    @expected_id.setter
    def expected_id(self, value: int | None) -> None:
        self._session.expected_id = value

    @property
    def framing(self) -> p.Framing:
        """The framing the link's frames use now (XOR until the board switched)."""
        return self._session.framing.current

    @property
    def window_bytes(self) -> int:
        return self._session.window_bytes

    @property
    def in_flight(self) -> int:
        """Requests sent and not yet answered."""
        return self._session.in_flight

    @property
    def in_flight_bytes(self) -> int:
        """Request bytes sent and not yet answered (bounded by ``window_bytes``)."""
        return self._session.in_flight_bytes

    @property
    def trace(self) -> TraceHook | None:
        return self._trace

    @trace.setter
    def trace(self, hook: TraceHook | None) -> None:
        """Called for every frame and garbage run; frames are also logged at DEBUG."""
        self._trace = hook
        wanted = hook is not None or logger.isEnabledFor(logging.DEBUG)
        self._session.trace = self._trace_item if wanted else None

    def _trace_item(self, direction: str, item: p.Decoded) -> None:
        logger.debug("%s %s %r", self.name, direction, item)
        if self._trace is not None:
            self._trace(TraceRecord(time.perf_counter_ns(), direction, item))  # type: ignore[arg-type]

    def subscribe(self, callback: Callable[[p.Event], None]) -> Callable[[], None]:
        """Call ``callback`` for each board-initiated frame (exceptions are logged)."""
        self._subscribers.append(callback)
        return lambda: self._subscribers.remove(callback)

    def on_state_change(self, callback: Callable[[LinkState], None]) -> Callable[[], None]:
        """Call ``callback`` whenever the link becomes ready, resyncs or closes."""
        self._state_listeners.append(callback)
        return lambda: self._state_listeners.remove(callback)

    # ---- requests ----------------------------------------------------------------------

    async def request(self, request: p.Request[R], *, timeout: float | None = None) -> R:
        """Send ``request`` and return its verified reply.

        ``timeout`` (default: the transport's) bounds the whole call, queueing and retries
        included.  Raises :class:`BoardError` (or a subclass) for an error reply,
        :class:`BoardTimeoutError`, :class:`LinkResyncError`, or
        :class:`BoardDisconnectedError`.
        """
        loop = self._loop
        if loop is None:
            exchange, data = self._session.send(request)
            if data:
                self.last_send = self._now()
                self._write(data)
            if exchange.done:  # refused at once (closed link): still a checkpoint for loops
                await anyio.lowlevel.checkpoint()
            else:
                await self._wait_event(exchange, self.timeout if timeout is None else timeout)
        else:
            # asyncio: the hot path, kept flat (one clock read, no extra coroutine or call).
            now = self._now()
            with self._lock:
                exchange, data = self._session.send(request)
                if data:
                    self.last_send = now
                    send_nowait = self._send_nowait
                    if send_nowait is None:
                        self._write(data)
                    else:
                        try:
                            send_nowait(data)
                        except WRITE_ERRORS as exc:
                            self._close(BoardDisconnectedError(f"{self.name}: write failed: {exc}"))
                future = None
                if not exchange.done:
                    future = exchange.waiter = loop.create_future()
                    deadline = exchange.deadline = now + (
                        self.timeout if timeout is None else timeout
                    )
                    alarm = self._alarm
                    if alarm is not None and deadline < alarm.armed_at:  # else it rings earlier
                        alarm.arm(deadline)
            if future is None:
                await anyio.lowlevel.checkpoint()
            else:
                try:
                    await future
                except BaseException:
                    with self._lock:
                        if not exchange.done:
                            exchange.deadline = math.inf  # abandoned: its reply is dropped
                            self._session.cancel(exchange)
                    raise
        if exchange.error is not None:
            raise exchange.error
        return exchange.reply  # type: ignore[return-value]

    def _on_alarm(self) -> None:
        """The link's one deadline alarm: expire what is due, re-arm for the next."""
        session = self._session
        now = self._now()
        with self._lock:
            for exchange in session.pending():
                if exchange.deadline <= now:
                    self._process(session.expire(exchange))
            next_deadline = min(
                (exchange.deadline for exchange in session.pending()), default=math.inf
            )
            alarm = self._alarm
            if alarm is not None and next_deadline < alarm.armed_at:
                alarm.arm(next_deadline)

    async def _wait_event(self, exchange: Exchange, limit: float) -> None:
        event = exchange.waiter = anyio.Event()
        try:
            with anyio.move_on_after(limit):
                await event.wait()
        except BaseException:
            if not exchange.done:
                self._session.cancel(exchange)
            raise
        if not exchange.done:
            self._process(self._session.expire(exchange))

    def request_from_thread(
        self,
        request: p.Request[Any],
        on_done: Callable[[Exchange], object],
        *,
        timeout: float | None = None,
    ) -> bool:
        """Put ``request`` on the link from a thread that is not the event loop's.

        For a server whose requests arrive on a network library's threads: sending them
        from there spares each round trip a hop into the loop before the request can
        reach the board.  True once the request is the session's: ``on_done(exchange)``
        then runs in the loop when it is done, ``exchange.reply`` or ``exchange.error``
        holding what :meth:`request` would return or raise (``timeout`` as there, from
        now).  False, having done nothing, when the request must go through the loop
        instead: not asyncio with a stream that pushes (the serial stream), the link
        resyncing or closed or traced (a trace hook runs in the loop), or the loop busy
        with the link this very moment (never waited for).  The link's lock puts
        requests from both sides into the session and on the wire in one order; the loop
        is not woken until the reply comes (or the deadline alarm must ring earlier).
        """
        send = self._send_from_thread
        if send is None or not self._lock.acquire(blocking=False):
            return False
        try:
            loop = self._loop
            if (
                loop is None
                or self._session.state is not SessionState.READY
                or self._trace is not None  # a user's hook runs in the loop only
            ):
                return False
            now = self._now()
            exchange, data = self._session.send(request)
            # Done in the loop's receive path, which waits for the lock; its callback runs
            # an iteration later, after the events that came before the reply.
            future = exchange.waiter = loop.create_future()
            future.add_done_callback(lambda _: on_done(exchange))
            deadline = exchange.deadline = now + (self.timeout if timeout is None else timeout)
            alarm = self._alarm
            if alarm is not None and deadline < alarm.armed_at:  # armed under the lock too
                alarm.arm(deadline)
            if data:
                self.last_send = now
                if not send(data):  # closed under us: the loop closes the link, as it would
                    with suppress(RuntimeError):  # the loop is gone: nobody waits
                        loop.call_soon_threadsafe(
                            self._close, BoardDisconnectedError(f"{self.name}: port closed")
                        )
            return True
        finally:
            self._lock.release()
