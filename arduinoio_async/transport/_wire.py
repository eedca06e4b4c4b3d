"""Bytes in and out of a link, and what they wake: the transport's wire half.

:class:`Wire` is the base of :class:`~arduinoio_async.transport.Transport`: it writes
(at once through a stream that declared :class:`~._streams.ImmediateSender`, else through
a writer task), receives (pushed by a :class:`~._streams.PushStream` or read by a reader
task), hands what arrives to the sans-IO session, wakes the callers whose replies came,
publishes board events, follows the session's state, and closes.  The transport's
``__init__`` sets the state declared here; the theory of operation is in :mod:`._link`.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from typing import Any

import anyio
import anyio.abc

from .. import protocol as p
from ..errors import ArduinoIOError, BoardDisconnectedError
from ..protocol.session import Received, Session, SessionState
from ._deadline import DeadlineAlarm
from ._link_types import PUBLIC_STATE, LinkState
from ._streams import Abilities, LinkAttribute

__all__ = ["WRITE_ERRORS", "Wire"]

logger = logging.getLogger("arduinoio_async.transport._link")

#: What a stream's write raises when the port is gone.
WRITE_ERRORS = (anyio.BrokenResourceError, anyio.ClosedResourceError, OSError)


class Wire:
    """The bytes of one link and the callers, events and listeners they reach."""

    stream: anyio.abc.ByteStream
    abilities: Abilities
    name: str
    #: Monotonic time of the last request sent (heartbeats skip busy links).
    last_send: float
    _session: Session
    _loop: asyncio.AbstractEventLoop | None
    _lock: Any
    _send_nowait: Callable[[bytes], None] | None
    _collect_sends: Callable[[], None] | None
    _outbox: bytearray
    _outbox_ready: anyio.Event
    _last_rx: float
    _rx_since_loss: bool
    _lost_at: float
    _changed: anyio.Event
    _watchers: int
    #: The session's state as last seen (a :class:`SessionState` string).
    _session_state: str
    _resync_needed: anyio.Event
    _alarm: DeadlineAlarm | None
    #: Releases a CRC reply held at the end of a read (see ``_hold_reply``).
    _hold_timer: asyncio.TimerHandle | None = None
    _now: Callable[[], float]
    _reboots: int
    _subscribers: list[Callable[[p.Event], None]]
    _state_listeners: list[Callable[[LinkState], None]]
    _state: LinkState

    @contextmanager
    def expecting_reboot(self) -> Iterator[None]:
        """Around a reboot the caller asked for (``Board.reset``): the board is silent
        while it boots, so requests meanwhile time out and the link resyncs as always,
        but that is no fault: it is logged at INFO instead of as a warning."""
        self._reboots += 1
        try:
            yield
        finally:
            self._reboots -= 1

    def _log_fault(self, message: str, *args: object) -> None:
        """A warning, or INFO while a reboot is expected (see :meth:`expecting_reboot`)."""
        if self._reboots:
            logger.info(message + " (the board is rebooting, as asked)", *args)
        else:
            logger.warning(message, *args)

    # ---- bytes in and out --------------------------------------------------------------

    def _write(self, data: bytes) -> None:
        send_nowait = self._send_nowait
        if send_nowait is None:
            self._outbox += data
            self._outbox_ready.set()
            return
        try:
            send_nowait(data)
        except WRITE_ERRORS as exc:
            self._close(BoardDisconnectedError(f"{self.name}: write failed: {exc}"))

    async def _writer(self) -> None:
        """For streams that cannot write without suspending: writes in call order."""
        while True:
            await self._outbox_ready.wait()
            self._outbox_ready = anyio.Event()
            while self._outbox:
                data = bytes(self._outbox)
                self._outbox.clear()
                try:
                    await self.stream.send(data)
                except WRITE_ERRORS as exc:
                    self._close(BoardDisconnectedError(f"{self.name}: write failed: {exc}"))
                    return

    async def _reader(self) -> None:
        try:
            while self._session.state is not SessionState.CLOSED:
                self._on_data(await self.stream.receive())
        except (anyio.EndOfStream, anyio.BrokenResourceError, anyio.ClosedResourceError) as exc:
            self._on_lost(exc)
        except OSError as exc:
            self._on_lost(exc)

    def _on_data(self, data: bytes) -> None:
        """Received bytes (in the fd-readable callback or the reader task)."""
        # No lock of its own: only the serial stream's sends come from other threads,
        # and its read callback, which calls this, holds the link's lock.
        session = self._session
        exchange = session.receive_reply(data)
        if exchange is not None:  # the common case, kept flat: wake its caller
            waiter = exchange.waiter
            if waiter is None:
                pass
            elif self._loop is None:
                waiter.set()
            elif not waiter.done():
                try:  # noqa: SIM105 - the hot path: no context manager object per reply
                    waiter.set_result(None)
                except asyncio.InvalidStateError:
                    pass  # cancelled since the check: see _wake
            if self._watchers:
                self._sync_state()
            return
        if session.state is not SessionState.READY:
            # Only a drain reads these, and a drain starts with a loss of sync, which
            # stamps ``_lost_at``: bytes received while in sync need no time stamp.
            self._last_rx = self._now()
            self._rx_since_loss = True
        hold = self._hold_timer
        if hold is not None:
            hold.cancel()  # these bytes decide the held reply
            self._hold_timer = None
        out = session.receive_data(data)
        self._process(out)
        if out.hold:
            self._hold_reply()
        if len(out.done) > 1 and self._collect_sends is not None:
            # Pipelining: the callers just woken may each send their next request in the
            # loop's next iteration; one write for all of them (see SerialByteStream).
            self._collect_sends()

    def _hold_reply(self) -> None:
        """Release the session's held reply once the line stayed quiet one byte time
        (the CRC slip guard, docs/protocol.md 7.7).  Timers run after the readable
        callbacks of their loop iteration, so a displaced byte already in the port's
        buffer is read (and cancels this) before it fires."""
        loop = self._loop
        if loop is None:  # a reader task without a loop handle: no quiet to wait for
            self._release_held()
            return
        baud = self.stream.extra(LinkAttribute.baudrate, None)
        byte_time = 10.0 / baud if isinstance(baud, int) and baud > 0 else 1e-5
        self._hold_timer = loop.call_later(byte_time, self._release_held)

    def _release_held(self) -> None:
        self._hold_timer = None
        with self._lock:
            self._process(self._session.release_held())

    def relay_failure(self, error: ArduinoIOError) -> None:
        """The oldest request in flight failed beyond the stream (a relaying stream's
        far end settled it, see ``Session.relay_failure``); call in received order."""
        with self._lock:
            self._process(self._session.relay_failure(error))

    def _on_lost(self, exc: BaseException | None) -> None:
        self._close(BoardDisconnectedError(f"{self.name}: port lost ({exc or 'EOF'})"))

    def _process(self, out: Received) -> None:
        """Deliver what the session produced: replies, events, bytes, state changes."""
        if out.outgoing:
            self.last_send = self._now()
            self._write(out.outgoing)
        for exchange in out.done:
            waiter = exchange.waiter
            if waiter is None:
                continue
            if isinstance(waiter, asyncio.Future):
                if not waiter.done():
                    _wake(waiter)
            else:
                waiter.set()
        if out.events:
            for event in out.events:
                self._publish(event)
        if out.lost is not None:
            self._log_fault("%s lost sync: %s", self.name, out.lost)
            self._lost_at = self._now()
            self._rx_since_loss = False
        if self._watchers or self._session.state is not self._session_state:
            self._sync_state()

    def _publish(self, event: p.Event) -> None:
        for callback in list(self._subscribers):
            try:
                callback(event)
            except Exception:
                logger.exception("%s: subscriber %r failed on %r", self.name, callback, event)

    def _sync_state(self) -> None:
        if self._watchers:
            changed, self._changed = self._changed, anyio.Event()
            changed.set()
        session_state = self._session.state
        if session_state is self._session_state:
            return
        self._session_state = session_state
        if session_state is not SessionState.READY:
            self._resync_needed.set()
        state = PUBLIC_STATE[session_state]
        if state is self._state:
            return
        self._state = state
        if state is LinkState.RESYNCING:
            pass  # logged with its reason where it was lost
        elif state is LinkState.CLOSED:
            logger.info("%s closed: %s", self.name, self._session.close_error)
        else:
            logger.info("%s in sync again", self.name)
        for callback in list(self._state_listeners):
            try:
                callback(state)
            except Exception:
                logger.exception("%s: state listener %r failed", self.name, callback)

    def _close(self, error: BoardDisconnectedError) -> None:
        with self._lock:
            if self._session.state is SessionState.CLOSED:
                return
            self._process(self._session.close(error))
        if self.abilities.push is not None:
            self.abilities.push.detach()
        if self._alarm is not None:
            self._alarm.disarm()


def _wake(waiter: asyncio.Future[None]) -> None:
    """Complete a caller's future that was pending a moment ago.  It may have been
    cancelled since: asyncio's Ctrl-C handler runs between any two bytecodes of a
    callback and cancels the main task, and with it the future that task awaits (seen
    as an ``InvalidStateError`` traceback above ``arduinoio bench``'s one-line error)."""
    with suppress(asyncio.InvalidStateError):
        waiter.set_result(None)
