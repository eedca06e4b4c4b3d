"""The event counters' counts, reported by the board as they count (counter reports).

Every pin with a counter role (D2/D3) asks the board for a report every ``every`` counts
(:func:`arduinoio_async.board.changes.watch_counter`, protocol extension 7.4); one read per
subscription gives the starting count.  A report per count is what a button or a slow
encoder wants, but a counter at kilohertz would then fill the link with reports the page
(about 20 updates a second) could never show.  So ``every`` follows the counting rate:
the smallest power of ten that keeps the reports at or under :data:`MAX_REPORTS_PER_S`,
measured over :data:`RATE_WINDOW`; when no report came for :data:`QUIET_AFTER` the
counter is slow again and every count is reported.  Counts are absolute, so a report the
board could not send loses nothing but that moment's update.

The stream, when it runs, carries both counts too; the page shows whichever arrived
last (the link delivers the board's frames in the order it sent them).  The
subscriptions follow roles, resets and links like the change events'
(:class:`~._sources.SubscribingSource`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from contextlib import AsyncExitStack
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import anyio

from .. import protocol as p
from ..board.changes import CountReports, watch_counter
from ..errors import ArduinoIOError
from ..protocol.pins import DigitalPin
from ._sources import Activity, Emit, PinKey, SubscribingSource

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["MAX_REPORTS_PER_S", "CountSource", "every_for"]

logger = logging.getLogger(__name__)

#: More reports than this a second would show the page nothing new.
MAX_REPORTS_PER_S = 50
#: Seconds over which the counting rate is measured.
RATE_WINDOW = 1.0
#: Seconds without a report after which every count is reported again.
QUIET_AFTER = 1.0
#: The largest report interval used (a power of ten below the protocol's 65535).
MAX_EVERY = 10_000


def every_for(counts_per_s: float, current: int) -> int:
    """The report interval for a counting rate (a power of ten).

    Up: the smallest interval that keeps the reports at or under MAX_REPORTS_PER_S.
    Down: only to an interval the rate fits with room to spare (half of it), so a rate
    near a boundary does not make the subscription flap.
    """

    def smallest(limit: float) -> int:
        every = 1
        while counts_per_s / every > limit and every < MAX_EVERY:
            every *= 10
        return every

    wanted = smallest(MAX_REPORTS_PER_S)
    if wanted >= current:
        return wanted
    return min(current, smallest(MAX_REPORTS_PER_S / 2))


@dataclass
class CountState:
    """What the page shows about the counter reports."""

    #: Report interval (counts) of each reported counter, by pin name.
    every: dict[str, int] = field(default_factory=dict)
    received: int = 0


class CountSource(SubscribingSource):
    """The counters' counts from the board's counter reports."""

    def __init__(
        self,
        board: Board,
        counters: Callable[[], Mapping[DigitalPin, PinKey]],
        *,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        super().__init__(board, counters, on_change=on_change)
        self.state = CountState()
        #: Counters whose count the reports follow now.
        self.reported: frozenset[DigitalPin] = frozenset()
        self._seen = dict.fromkeys(DigitalPin, 0)  # any model's pins (a Mega's D53 too)
        self._failure: ArduinoIOError | None = None

    @property
    def supported(self) -> bool:
        return bool(self.board.capabilities.features & p.Feature.COUNTER_REPORTS)

    def describe(self) -> dict[str, object]:
        return {
            "kind": "counter reports",
            "running": self.running,
            "supported": self.supported,
            "every": dict(self.state.every),
            "received": self.state.received,
            "error": self.error if self.supported else "not in this firmware",
        }

    def _available(self) -> bool:
        return super()._available() and self.supported

    async def _run_once(self, emit: Emit) -> None:
        link = self.board.link
        epoch = self._epoch()
        pins = sorted(epoch[2])
        self._failure = None
        async with anyio.create_task_group() as tg:
            with self._cancellable():
                for pin in pins:
                    tg.start_soon(self._follow, pin, emit, tg.cancel_scope)
                self.reported = frozenset(pins)
                self._on_change()
                try:
                    await self._while_current(link, epoch)
                finally:
                    self.reported = frozenset()
                    self.state.every.clear()
            tg.cancel_scope.cancel()  # every watch ends with its own unsubscribe
        if self._failure is not None:
            raise self._failure

    async def _follow(self, pin: DigitalPin, emit: Emit, group: anyio.CancelScope) -> None:
        """Reports of one counter, re-subscribed whenever its rate asks for a new interval."""
        every = 1
        try:
            while True:
                async with AsyncExitStack() as stack:
                    # Not cancelled halfway: the board would report to nobody.
                    with anyio.CancelScope(shield=True):
                        reports = await stack.enter_async_context(
                            watch_counter(self.board, pin, every)
                        )
                    # Also after a new interval: the last report may be up to ``every``
                    # counts behind a counter that has just stopped.
                    await self._read_count(pin, emit)
                    self.state.every[pin.name] = every
                    self._on_change()
                    every = await self._take_reports(pin, reports, every, emit)
        except ArduinoIOError as exc:  # the run loop reports it and starts again
            self._failure = exc
            group.cancel()

    async def _read_count(self, pin: DigitalPin, emit: Emit) -> None:
        """The starting count (dropped if a report overtook the read: it is newer)."""
        before = self._seen[pin]
        reply = await self.board.request(p.CounterRead(pin))
        if self._seen[pin] == before:
            emit(Activity(time=time.time(), counts={pin: reply.count}))

    async def _take_reports(
        self, pin: DigitalPin, reports: CountReports, every: int, emit: Emit
    ) -> int:
        """Pass reports on until the counting rate wants another interval; return it."""
        window: tuple[float, int] | None = None
        while True:
            with anyio.move_on_after(QUIET_AFTER if every > 1 else math.inf) as quiet:
                report = await reports.__anext__()
            if quiet.cancelled_caught:
                return 1
            self._seen[pin] += 1
            self.state.received += 1
            emit(Activity(time=time.time(), counts={pin: report.count}))
            now = anyio.current_time()
            if window is None or report.count < window[1]:  # first, or the count was cleared
                window = (now, report.count)
                continue
            elapsed = now - window[0]
            if elapsed >= RATE_WINDOW:
                wanted = every_for((report.count - window[1]) / elapsed, every)
                if wanted != every:
                    return wanted
                window = (now, report.count)
