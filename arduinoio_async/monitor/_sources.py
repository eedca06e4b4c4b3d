"""Where the monitor's live data comes from: the board's stream and its change events.

The monitor does not poll pins.  Two sources push what the page shows, and each turns
what it receives into :class:`Activity`:

* :class:`StreamSource` asks the board to sample itself from its timer
  (:meth:`arduinoio_async.board.Board.stream` with the analog channels, levels, edges and
  counters): the analog plots, and the levels of pins nobody watches (outputs, PWM).
* :class:`~._changes.ChangeSource` subscribes every digital input to the board's change
  events (:mod:`arduinoio_async.board.changes`): each edge arrives as it happens, with its
  level and the board's sequence number, so the page counts every edge and shows lost
  events.  While a pin is watched, its level and edges come from the events only.

Anything that produces activities fits the :class:`ActivitySource` protocol; the panel
merges what its sources emit.  Every source owns a retry loop (:class:`SupervisedSource`):
a source that fails (board reset, replug, link error) reports it in its state and starts
again after a short pause, so a flaky board never ends the monitor.
:meth:`SupervisedSource.paused` stops a source around an operation that would break it
(a reset) and starts it afterwards.
"""

from __future__ import annotations

import logging
import time
from collections.abc import AsyncIterator, Callable, Iterator, Mapping, Sequence
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import anyio

from ..board.streaming import Sample
from ..errors import ArduinoIOError
from ..protocol.pins import AnalogPin, DigitalPin
from ..transport import LinkState

if TYPE_CHECKING:
    from ..board import Board
    from ..transport import Transport

__all__ = [
    "Activity",
    "ActivitySource",
    "StreamSource",
    "StreamState",
    "SubscribingSource",
    "SupervisedSource",
]

logger = logging.getLogger(__name__)

#: How long a failed source waits before it is started again.
RETRY_INTERVAL = 0.5
#: How often a subscribing source compares the board's session tag, link and pin roles
#: with the ones it subscribed for (a local check, nothing is sent to the board).
SUPERVISE_INTERVAL = 0.5

#: What identifies a pin's subscription (its handle and role, as the page shows it): a
#: new handle or role of the pin ends the board's subscription, so either asks for a new one.
PinKey = tuple[int, object]


@dataclass(frozen=True, slots=True)
class Activity:
    """One observation of the board: the same shape whatever the source."""

    #: Wall-clock seconds (``time.time()`` scale) of the observed instant.
    time: float
    analog: dict[AnalogPin, int] = field(default_factory=dict)
    #: Bit n = level of Dn, every pin at once (the stream); ``None`` when not known.
    levels: int | None = None
    #: Levels of single pins (change events): the source reports only these pins, and
    #: owns their levels and edges while it watches them.
    pin_levels: dict[DigitalPin, bool] = field(default_factory=dict)
    #: Bit n = Dn rose / fell since the source's previous activity.
    rose: int = 0
    fell: int = 0
    #: Counts of the D2/D3 event counters, if known (the stream: both at once).
    counters: tuple[int, int] | None = None
    #: Counts of single counters (counter reports).
    counts: dict[DigitalPin, int] = field(default_factory=dict)


Emit = Callable[[Activity], None]


class ActivitySource(Protocol):
    """Produces activities for one board until cancelled."""

    async def run(self, emit: Emit) -> None: ...

    def describe(self) -> dict[str, object]:
        """The source's state for the page (JSON-ready)."""
        ...


class SupervisedSource:
    """The retry loop, the pause and the restart every source of one board shares.

    A subclass implements :meth:`_run_once` (one subscription, from start to stop) and
    wraps the part that may be cut short in :meth:`_cancellable`; starting and stopping a
    subscription on the board are never cancelled halfway, which would leave the board
    sending with nobody to stop it.
    """

    def __init__(self, board: Board, *, on_change: Callable[[], None] = lambda: None) -> None:
        self.board = board
        self.running = False
        self.error = ""
        self._on_change = on_change
        self._pause_depth = 0
        self._wake = anyio.Event()
        self._stopped = anyio.Event()
        self._stopped.set()
        self._scope: anyio.CancelScope | None = None
        self._restart = False

    def restart(self) -> None:
        """Start again with fresh parameters (new channels, new roles, a reset board)."""
        self._restart = True
        if self._scope is not None:
            self._scope.cancel()
        self._wake.set()

    @asynccontextmanager
    async def paused(self) -> AsyncIterator[None]:
        """Stop the source for the body (it is started again afterwards, also on errors)."""
        self._pause_depth += 1
        try:
            if self._scope is not None:
                self._scope.cancel()
            await self._stopped.wait()
            yield
        finally:
            self._pause_depth -= 1
            self._wake.set()

    def _available(self) -> bool:
        """Whether the source can start now (the board is connected and not paused)."""
        return not self._pause_depth and self.board.connected

    async def run(self, emit: Emit) -> None:
        while True:
            self._wake = anyio.Event()
            if not self._available():
                with anyio.move_on_after(RETRY_INTERVAL):
                    await self._wake.wait()
                continue
            self._restart = False
            self._stopped = anyio.Event()
            try:
                try:
                    await self._run_once(emit)
                finally:
                    self._scope = None
                    self._stopped.set()
                    self._set_running(False)
            except ArduinoIOError as exc:
                logger.info("monitor: %s on %s stopped: %s", type(self).__name__, self.board, exc)
                self.error = str(exc)
                self._on_change()
                with anyio.move_on_after(RETRY_INTERVAL):
                    await self._wake.wait()

    async def _run_once(self, emit: Emit) -> None:
        raise NotImplementedError

    @contextmanager
    def _cancellable(self) -> Iterator[None]:
        """The part of a run that :meth:`restart` and :meth:`paused` may cut short."""
        with anyio.CancelScope() as scope:
            self._scope = scope
            if self._pause_depth or self._restart:  # asked while the start was under way
                scope.cancel()
            self.error = ""
            self._set_running(True)
            yield

    def _set_running(self, running: bool) -> None:
        if self.running != running:
            self.running = running
            self._on_change()


class SubscribingSource(SupervisedSource):
    """A source that subscribes pins of some roles to board-initiated reports.

    A new configuration of a pin ends its subscription, and after a reset of the board
    the library's restore brings the subscriptions back but not what happened between
    the reset and the restore: the subscription is made again (and its starting state
    read again) when the board's boot (its session tag), its link or the pins (``pins``:
    each with a :data:`PinKey`) change.  That check looks
    at the board object's own records every :data:`SUPERVISE_INTERVAL`, with no traffic
    to the board; a closed link is noticed at once.
    """

    def __init__(
        self,
        board: Board,
        pins: Callable[[], Mapping[DigitalPin, PinKey]],
        *,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        super().__init__(board, on_change=on_change)
        self._pins = pins

    def _epoch(self) -> tuple[int, object, dict[DigitalPin, PinKey]]:
        """What a subscription depends on: the board's boot, its link, the pins."""
        board = self.board
        link = board.link if board.connected else None
        return board.session, link, dict(self._pins())

    async def _while_current(self, link: Transport, epoch: object) -> None:
        """Return once ``link`` closes or the epoch the subscription was made in is over."""
        closed = anyio.Event()

        def on_state(state: LinkState) -> None:
            if state is LinkState.CLOSED:
                closed.set()

        stop_listening = link.on_state_change(on_state)
        try:
            while not closed.is_set() and link.state is not LinkState.CLOSED:
                if self._epoch() != epoch:
                    return
                with anyio.move_on_after(SUPERVISE_INTERVAL):
                    await closed.wait()
        finally:
            stop_listening()


@dataclass
class StreamState:
    """What the page shows about the stream."""

    period_ms: float = 0.0
    channels: tuple[str, ...] = ()
    received: int = 0
    lost: int = 0


class _Clock:
    """Board microseconds (wrapping at 2**32) to wall-clock seconds, anchored at start."""

    def __init__(self) -> None:
        self._anchor_wall = 0.0
        self._last_us: int | None = None
        self._elapsed_us = 0

    def to_wall(self, board_us: int) -> float:
        if self._last_us is None:
            self._anchor_wall = time.time()
        else:
            self._elapsed_us += (board_us - self._last_us) & 0xFFFFFFFF
        self._last_us = board_us
        return self._anchor_wall + self._elapsed_us / 1e6


def activity_of(sample: Sample, wall_time: float) -> Activity:
    return Activity(
        time=wall_time,
        analog=dict(sample.analog),
        levels=sample.levels,
        rose=sample.rose or 0,
        fell=sample.fell or 0,
        counters=sample.counters,
    )


class StreamSource(SupervisedSource):
    """Levels, edges, counters and analog values from the board's firmware-timed stream.

    ``analog_pins`` is called at every (re)start, so the channels follow the board's
    configuration (A4/A5 leave the stream when the I2C bus takes them).  With
    ``enabled=False`` the stream is never started (the page then shows what change
    events deliver, and no analog plot).
    """

    def __init__(
        self,
        board: Board,
        analog_pins: Callable[[], Sequence[AnalogPin]],
        *,
        period_ms: float = 20.0,
        enabled: bool = True,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        super().__init__(board, on_change=on_change)
        self.period_ms = period_ms
        self.enabled = enabled
        self.state = StreamState(period_ms=period_ms)
        self._analog_pins = analog_pins

    def describe(self) -> dict[str, object]:
        s = self.state
        return {
            "kind": "firmware-timed stream",
            "enabled": self.enabled,
            "running": self.running,
            "period_ms": s.period_ms,
            "channels": list(s.channels),
            "received": s.received,
            "lost": s.lost,
            "error": self.error,
        }

    async def run(self, emit: Emit) -> None:
        if self.enabled:
            await super().run(emit)

    async def _run_once(self, emit: Emit) -> None:
        pins = tuple(self._analog_pins())
        clock = _Clock()
        async with self.board.stream(
            analog=pins, levels=True, edges=True, counters=True, period_ms=self.period_ms
        ) as samples:
            self.state = StreamState(period_ms=self.period_ms, channels=tuple(p.name for p in pins))
            # Only the reading is cancelled: a start or stop request cut in half would
            # leave the board streaming with nobody to stop it.
            with self._cancellable():
                async for sample in samples:
                    self.state.received = samples.received
                    self.state.lost = samples.lost
                    emit(activity_of(sample, clock.to_wall(sample.board_time_us)))
