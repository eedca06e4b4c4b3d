"""Regaining sync: drain the line, then probe, until the board answers in frames again.

When the session loses sync it fails what was in flight (or queues idempotent requests
again) and the resync task here drains the line and probes: the drain ends when nothing
was sent for ``quiet_time`` (longer than the board's 10 ms inter-byte gap, so the board is
ready for a frame) and the line was quiet as long, or -- with a stream running, when the
line never goes quiet -- what arrived decoded into whole frames.  The probe ends at its
answer, or at once when garbage comes instead; unanswered probes back off, never beyond
``max_silence`` (a board whose failsafe is armed must hear a frame in time).

While a failsafe is armed (``max_silence`` set) the drain waits ``ARMED_QUIET_TIME`` (20
ms, twice the board's gap) and an unanswered probe is followed by the next one as soon
as the drain allows, without a backoff: a keepalive poll corrupted on its way to the board
and a lost first probe left the board ~110 ms without a frame (30 ms drain, 25 ms for the
probe's answer, 30 ms of backoff, after the heartbeat before the poll), and a 100 ms
failsafe tripped on a healthy host.
"""

from __future__ import annotations

import logging

import anyio
import anyio.lowlevel

from ..protocol.session import SessionState
from ._link_types import ARMED_QUIET_TIME, MAX_DRAIN, MAX_PROBE_BACKOFF
from ._wire import Wire

__all__ = ["Resyncing"]

logger = logging.getLogger("arduinoio_async.transport._link")


class Resyncing(Wire):
    """The resync task of a link (the transport starts :meth:`_resyncer`)."""

    timeout: float
    quiet_time: float
    max_silence: float | None

    # ---- regaining sync ----------------------------------------------------------------

    async def _wait_changed(self, until: float) -> None:
        """Until the session's state changes, data arrives, or ``until``."""
        changed = self._changed
        self._watchers += 1
        try:
            with anyio.move_on_after(max(0.0, until - self._now())):
                await changed.wait()
        finally:
            self._watchers -= 1

    async def _resyncer(self) -> None:
        session = self._session
        while True:
            if session.state is SessionState.READY:
                await self._resync_needed.wait()
                self._resync_needed = anyio.Event()
            if session.state is SessionState.CLOSED:
                return
            backoff = self.quiet_time
            unanswered = 0
            while session.state is SessionState.DRAINING:
                await self._drain()
                if session.state is not SessionState.DRAINING:
                    break
                with self._lock:
                    probe = session.start_probe()
                    self._sync_state()
                    self.last_send = self._now()
                    self._write(probe)
                patience = self.timeout
                if self.max_silence is not None:
                    patience = min(patience, self.max_silence)
                give_up = self._now() + patience
                while session.state is SessionState.PROBING and self._now() < give_up:
                    await self._wait_changed(give_up)
                if session.state is SessionState.PROBING:
                    with self._lock:
                        session.probe_failed("no answer to the ID probe")
                    unanswered += 1
                    if unanswered & (unanswered - 1) == 0:  # 1, 2, 4, 8...: a silent board
                        # probed every heartbeat (failsafe armed) must not flood the log
                        self._log_fault(
                            "%s: no answer to the ID probe (%d in a row)", self.name, unanswered
                        )
                    if self.max_silence is None:
                        await anyio.sleep(backoff)
                        backoff = min(backoff * 2, MAX_PROBE_BACKOFF)
                    else:  # armed: the next probe as soon as the drain allows
                        await anyio.lowlevel.checkpoint()
                elif session.state is SessionState.DRAINING:
                    logger.info(
                        "%s: probe failed (%s); draining again", self.name, session.last_loss
                    )
            if session.state is SessionState.READY:
                with self._lock:
                    data = session.admit()
                    if data:
                        self.last_send = self._now()
                        self._write(data)

    async def _drain(self) -> None:
        """Until the board is ready for a frame and the line is drained (see above)."""
        session = self._session
        give_up = self._now() + MAX_DRAIN
        quiet = self.quiet_time
        if self.max_silence is not None:
            quiet = min(quiet, ARMED_QUIET_TIME)
        while session.state is SessionState.DRAINING:
            now = self._now()
            sent_quiet = now - self.last_send >= quiet
            line_quiet = now - max(self._last_rx, self._lost_at) >= quiet
            aligned = self._rx_since_loss and session.aligned
            if (sent_quiet and (line_quiet or aligned)) or now >= give_up:
                return
            if not sent_quiet:
                until = self.last_send + quiet
            else:
                until = max(self._last_rx, self._lost_at) + quiet
            await self._wait_changed(max(min(until, give_up), now + 0.001))
