"""The failsafe and the keepalive: what keeps a board safe when its host falls silent.

The board's failsafe is a link watchdog: once armed it puts chosen outputs into a safe
state when no valid frame arrives for its timeout.  The host side, :class:`Failsafe`, keeps
what was armed (to arm it again after a reset or a trip), hears the trip (the board's
event, a refused request, or the status flag) and tells listeners, and runs the keepalive:
an idle link gets a status poll often enough to feed the watchdog, which also notices a
board that reset by itself.  Everything goes through the board's public API; the
:class:`~arduinoio_async.board.Board` methods ``arm_failsafe``, ``keepalive``, ... hand
over to it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass
from typing import Generic, TypeVar

import anyio
import anyio.lowlevel

from .. import protocol as p
from ..errors import ArduinoIOError, LinkError, PinRoleError, StaleHandleError, ValueRangeError
from ..transport import LinkState, Transport
from ._core import BoardCore
from .handles import DigitalOutput, Gpio, PinHandle, PulseOutput
from .motors import DutyPwm, Motor

__all__ = ["HEARTBEATS_PER_TIMEOUT", "IDLE_HEARTBEAT", "Failsafe", "FailsafeConfig", "Recovery"]

logger = logging.getLogger(__name__)

#: The board the failsafe guards (a Board; its listeners are called with it).
B = TypeVar("B", bound=BoardCore)

#: Status poll interval of an idle link without failsafe (detects resets, costs ~1 frame).
IDLE_HEARTBEAT = 0.25
#: With the failsafe armed the host polls this many times per timeout while idle.
HEARTBEATS_PER_TIMEOUT = 4
#: Status polls of the keepalive waiting for their replies at most (a bound for a board
#: that stopped answering: each poll ends at its timeout).
MAX_POLLS = 16

#: What the keepalive runs when the board reset by itself or its failsafe fired.
Recovery = Callable[[], Awaitable[None]]


@dataclass(frozen=True)
class FailsafeConfig:
    """An armed failsafe: the timeout and the safe state of each output pin."""

    timeout_ms: int
    safe_states: tuple[p.FailsafeSafeState, ...]


class Failsafe(Generic[B]):
    """One board's failsafe as the host runs it: what is armed, trip news, the keepalive."""

    def __init__(self, board: B) -> None:
        self.board = board
        #: The armed failsafe, or None when disarmed (kept to re-arm after a reset).
        self.config: FailsafeConfig | None = None
        self.tripped = False
        self._listeners: list[Callable[[B], None]] = []
        self._unsubscribe: Callable[[], None] | None = None
        #: Wakes the keepalive: the failsafe was armed, a poll brought news, a recovery ended.
        self._wake = anyio.Event()
        #: The newest poll answer not looked at yet, with the time its poll was sent.
        self._news: tuple[float, p.ReadStatusReply] | None = None
        #: Status polls sent (or waiting to be) and not yet answered.
        self._polls = 0
        #: A session tag not ours that the last poll answer reported (None: it was ours).
        self._other_session: int | None = None

    # ---- trip news ---------------------------------------------------------------------

    def listen(self, link: Transport) -> None:
        """Hear the board's trip report on ``link`` (and no longer on the previous link)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
        self._unsubscribe = link.subscribe(self._on_event)

    def _on_event(self, event: p.Event) -> None:
        if isinstance(event, p.FailsafeTripped):
            self.notice_trip()

    def notice_trip(self) -> None:
        """The failsafe fired: note it once and tell every listener."""
        if self.tripped:
            return
        self.tripped = True
        logger.warning("%r: the failsafe fired", self.board)
        for callback in list(self._listeners):
            try:
                callback(self.board)
            except Exception:  # a listener's bug must not hurt the link or the caller
                logger.exception("%r: on_failsafe callback %r failed", self.board, callback)

    def on_trip(self, callback: Callable[[B], None]) -> Callable[[], None]:
        """Call ``callback(board)`` when the failsafe fires; returns the unsubscriber."""
        self._listeners.append(callback)
        return lambda: self._listeners.remove(callback)

    # ---- arming ------------------------------------------------------------------------

    def checked_config(
        self, timeout_ms: int, safe_states: Mapping[PinHandle | Motor, bool | float]
    ) -> FailsafeConfig:
        """The failsafe ``timeout_ms`` and ``safe_states`` describe, checked before use."""
        if (
            isinstance(timeout_ms, bool)
            or not isinstance(timeout_ms, int)
            or not p.FAILSAFE_MIN_TIMEOUT_MS <= timeout_ms <= p.FAILSAFE_MAX_TIMEOUT_MS
        ):
            raise ValueRangeError(
                "failsafe timeout (ms)",
                timeout_ms,
                f"a whole number of ms, {p.FAILSAFE_MIN_TIMEOUT_MS}-{p.FAILSAFE_MAX_TIMEOUT_MS}",
            )
        board = self.board
        requests = []
        items: list[tuple[PinHandle, bool | float]] = []
        for key, state in safe_states.items():
            if isinstance(key, Motor):  # a motor's safe state is stopped: duty 0 on its PWM
                items += [(h, 0.0) for h in key.pwm_handles]
            else:
                items.append((key, state))
        for handle, state in items:
            if getattr(handle, "board", None) is not board:
                raise StaleHandleError(
                    repr(handle), f"belongs to another board, not to {board!r}; its pin is not ours"
                )
            handle.check_usable()
            if isinstance(handle, DutyPwm):
                duty = handle.check_duty(float(state))
                requests.append(p.FailsafeSafeState(handle.pin, p.SafeKind.DUTY, duty))
            elif isinstance(handle, PulseOutput):
                pulse = handle.check_pulse(int(state))
                requests.append(p.FailsafeSafeState(handle.pin, p.SafeKind.PULSE, pulse))
            elif isinstance(handle, DigitalOutput | Gpio):
                requests.append(p.FailsafeSafeState(handle.pin, p.SafeKind.LEVEL, int(bool(state))))
            else:
                raise PinRoleError(handle.pin.name, handle.ROLE, "failsafe output")
        return FailsafeConfig(timeout_ms, tuple(requests))

    async def arm(
        self, timeout_ms: int, safe_states: Mapping[PinHandle | Motor, bool | float]
    ) -> None:
        """Check, keep and arm; the heartbeat speeds up at once (see ``Board.arm_failsafe``)."""
        self.config = self.checked_config(timeout_ms, safe_states)
        await self.arm_on(self.board.link)
        self._wake.set()

    async def arm_on(self, link: Transport) -> None:
        """Send the kept safe states and arm, on ``link`` (a fresh boot's, when adopting)."""
        if self.config is None:
            return
        for request in self.config.safe_states:
            await link.request(request)
        await link.request(p.FailsafeArm(self.config.timeout_ms))
        self.tripped = False

    async def disarm(self) -> None:
        """Disarm the board's watchdog and forget the armed set-up (and any trip)."""
        await self.board.request(p.FailsafeDisarm())
        self.config = None
        self.tripped = False

    async def rearm(self, *, restore: bool = True) -> None:
        """After a trip: arm again and (by default) put every pin role back as it was."""
        link = self.board.link
        await self.arm_on(link)
        if restore:
            for setup in self.board.roles.setups():
                await link.request(setup)
            await self.board.watches.restore_on(link)  # a replayed set-up ended them

    # ---- keepalive ---------------------------------------------------------------------

    def heartbeat_interval(self) -> float:
        """Seconds the link may stay idle before the keepalive sends a status poll:
        :data:`IDLE_HEARTBEAT`, or a fraction of the armed timeout, so that
        :data:`HEARTBEATS_PER_TIMEOUT` polls fall within it."""
        if self.config is None:
            return IDLE_HEARTBEAT
        return min(IDLE_HEARTBEAT, self.config.timeout_ms / 1000 / HEARTBEATS_PER_TIMEOUT)

    async def keepalive(
        self, link: Transport, *, on_reset: Recovery | None = None, on_trip: Recovery | None = None
    ) -> None:
        """Poll the board's status while ``link`` is idle, until it closes.

        Feeds the failsafe, notices a trip that no event reported, and (with
        ``on_reset``) a board that has reset by itself.

        The polls go out on the heartbeat's schedule whatever an earlier poll still waits
        for: each poll runs in a task of its own, so a poll whose reply was lost waits
        out its timeout beside the next ones instead of silencing the host for that long
        (a 0.5 s silence tripped a 100 ms failsafe on every lost reply).  What the polls
        learn is handled here, one recovery at a time, and a recovery runs in a task of
        its own too: its requests may lose replies as well, and the heartbeat goes on.
        """
        self._news = None
        recovery: anyio.Event | None = None  # set when the running recovery ended
        recovered_at = -math.inf  # news from polls sent before this is stale
        polled_at = -math.inf  # when the last poll was started (it may wait to be sent)
        async with anyio.create_task_group() as tasks:
            while link.state is not LinkState.CLOSED:
                interval = self.heartbeat_interval()
                # A resync waits for its probe's answer no longer than a heartbeat either.
                link.max_silence = None if self.config is None else interval
                wake = self._wake
                if self._news is None:
                    due = max(link.last_send, polled_at) + interval
                    with anyio.move_on_after(due - anyio.current_time()):
                        await wake.wait()  # arming shortens the interval; news comes in
                if wake.is_set():
                    self._wake = anyio.Event()
                if recovery is not None and recovery.is_set():
                    recovery, recovered_at = None, anyio.current_time()
                news, self._news = self._news, None
                if news is not None and recovery is None and news[0] > recovered_at:
                    action = self._recovery_for(news[1], on_reset, on_trip)
                    if action is not None:
                        recovery = anyio.Event()
                        tasks.start_soon(self._recover, *action, recovery)
                if anyio.current_time() - max(link.last_send, polled_at) < interval * 0.9:
                    continue  # other traffic fed the watchdog
                if self._polls >= MAX_POLLS or (self._polls and link.state is not LinkState.READY):
                    # Polls wait unsent while the link resyncs (whose probes feed the
                    # watchdog): one waiting is enough.
                    await anyio.sleep(interval)
                    continue
                polled_at = anyio.current_time()
                tasks.start_soon(self._poll, link)
            tasks.cancel_scope.cancel()

    async def _poll(self, link: Transport) -> None:
        """One status poll; its answer, stamped with when it was asked, is news."""
        asked = anyio.current_time()
        self._polls += 1  # counted in the task: one cancelled before it ran is never counted
        try:
            status = await link.request(p.ReadStatus())
        except LinkError:
            return
        finally:
            self._polls -= 1
        if self._news is None or self._news[0] < asked:
            self._news = (asked, status)
            self._wake.set()

    def _recovery_for(
        self, status: p.ReadStatusReply, on_reset: Recovery | None, on_trip: Recovery | None
    ) -> tuple[Recovery, str] | None:
        """What a poll's answer calls for: a restore after a reset, a re-arm, or nothing.

        A session tag other than ours counts once a second answer repeats it: the 8-bit
        checksum lets about one damaged frame in 256 through, and a noisy line would
        otherwise "reset" a board that never did (a real reset shows at the next poll).
        """
        if status.session != self.board.session:
            seen, self._other_session = self._other_session, status.session
            if on_reset is not None and seen == status.session:
                return on_reset, "the restore after a reset"
            return None
        self._other_session = None
        if status.flags & p.StatusFlags.FAILSAFE_TRIPPED:
            self.notice_trip()
        if self.tripped and on_trip is not None:
            return on_trip, "re-arming after a failsafe trip"
        return None

    async def _recover(self, action: Recovery, what: str, done: anyio.Event) -> None:
        """Run a recovery; a board or link failure during it is logged, never raised.

        The keepalive runs next to other boards' tasks: a restore that fails because the
        board reset again or its cable was pulled must not take them down.  The board's
        session still differs (or the trip flag is still set), so the next heartbeat tries
        again, and a closed link ends the keepalive.
        """
        try:
            await action()
        except ArduinoIOError as exc:
            logger.warning("%r: %s failed: %s", self.board, what, exc)
            await anyio.lowlevel.checkpoint()
        finally:
            done.set()
            self._wake.set()
