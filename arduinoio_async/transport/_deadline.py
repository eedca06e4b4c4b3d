"""Deadlines on asyncio without a timer in the event loop.

Why not ``loop.call_at``: while any timer is scheduled, asyncio's loop computes a
``select()`` timeout on every iteration and the kernel arms a timer for every wait.  A
link's requests take some 20 us on a pseudo-terminal, and that cost was a fifth of the
library's CPU per request (``arduinoio bench --host``), for deadlines that are almost
never reached.  So each link keeps only its *earliest* deadline here, and one watchdog
thread per process sleeps until the earliest of all, then asks the link's loop
(``call_soon_threadsafe``) to expire what is due; the loop itself blocks without a
timeout.  Arming takes a lock only when a deadline earlier than the armed one appears (a
link going busy after idling, a shorter per-request timeout): the steady stream of later
deadlines of a busy link costs nothing.  Times are ``time.monotonic()`` values.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import threading
import time
from collections.abc import Callable

__all__ = ["DeadlineAlarm"]


class DeadlineAlarm:
    """Calls ``callback`` in ``loop`` soon after the ``time.monotonic()`` value armed."""

    __slots__ = ("_callback", "_loop", "armed_at")

    def __init__(self, loop: asyncio.AbstractEventLoop, callback: Callable[[], None]) -> None:
        self._loop = loop
        self._callback = callback
        #: The armed time, or ``math.inf`` when disarmed (read freely; set by the methods).
        self.armed_at = math.inf

    def arm(self, when: float) -> None:
        """Ring at ``when`` instead of the time armed before (from the loop's thread, or
        from another holding the lock its owner arms under, see ``Transport``)."""
        self.armed_at = when
        _WATCHDOG.arm(self, when)

    def disarm(self) -> None:
        self.armed_at = math.inf
        _WATCHDOG.disarm(self)

    def _ring(self) -> None:
        """From the watchdog thread: the armed time has come."""
        with contextlib.suppress(RuntimeError):  # the loop was closed meanwhile
            self._loop.call_soon_threadsafe(self._rung)

    def _rung(self) -> None:
        self.armed_at = math.inf
        self._callback()


class _Watchdog:
    """The one thread that sleeps until the earliest armed alarm of the process."""

    def __init__(self) -> None:
        self._condition = threading.Condition()
        self._alarms: dict[DeadlineAlarm, float] = {}
        self._wake_at = math.inf
        self._thread: threading.Thread | None = None

    def arm(self, alarm: DeadlineAlarm, when: float) -> None:
        with self._condition:
            self._alarms[alarm] = when
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._run, name="arduinoio deadlines", daemon=True
                )
                self._thread.start()
            elif when < self._wake_at:
                self._condition.notify()

    def disarm(self, alarm: DeadlineAlarm) -> None:
        with self._condition:
            self._alarms.pop(alarm, None)

    def _run(self) -> None:
        with self._condition:
            while True:
                now = time.monotonic()
                due = [alarm for alarm, when in self._alarms.items() if when <= now]
                for alarm in due:
                    del self._alarms[alarm]
                    alarm._ring()
                self._wake_at = min(self._alarms.values(), default=math.inf)
                self._condition.wait(None if self._wake_at == math.inf else self._wake_at - now)


_WATCHDOG = _Watchdog()


def _forget_in_child() -> None:
    """A forked child has no watchdog thread (nor the parent's loops): start afresh."""
    global _WATCHDOG
    _WATCHDOG = _Watchdog()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_in_child)
