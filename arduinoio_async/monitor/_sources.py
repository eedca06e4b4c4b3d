"""Where the monitor's live data comes from: the board's firmware-timed sample stream.

The monitor does not poll pins.  It asks the board to sample itself from its timer
(:meth:`arduinoio_async.board.Board.stream` with levels, edges, counters and the analog
channels) and turns every sample into an :class:`Activity`.  Anything that can produce
activities fits the :class:`ActivitySource` protocol, so a source of input-change events
can replace the stream (or run beside it: the monitor merges whatever its sources emit).

A source owns a retry loop: a stream that fails (board reset, replug, link error) is
reported through :attr:`StreamSource.state` and started again after a short pause, so a
flaky board never ends the monitor.  :meth:`StreamSource.paused` stops the stream around
an operation that would break it (a reset) and starts it afterwards.
"""

from __future__ import annotations

import logging
import time
from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import anyio

from ..errors import ArduinoIOError
from ..protocol.pins import AnalogPin
from ..streaming import Sample

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["Activity", "ActivitySource", "StreamSource", "StreamState"]

logger = logging.getLogger(__name__)

#: How long a failed stream waits before it is started again.
RETRY_INTERVAL = 0.5


@dataclass(frozen=True, slots=True)
class Activity:
    """One observation of the board: the same shape whatever the source."""

    #: Wall-clock seconds (``time.time()`` scale) of the sampling instant.
    time: float
    analog: dict[AnalogPin, int] = field(default_factory=dict)
    #: Bit n = level of Dn; ``None`` when the source does not know the levels.
    levels: int | None = None
    #: Bit n = Dn rose / fell since the source's previous activity.
    rose: int = 0
    fell: int = 0
    #: Counts of the D2/D3 event counters, if known.
    counters: tuple[int, int] | None = None


Emit = Callable[[Activity], None]


class ActivitySource(Protocol):
    """Produces activities for one board until cancelled."""

    async def run(self, emit: Emit) -> None: ...

    def describe(self) -> dict[str, object]:
        """The source's state for the page (JSON-ready)."""
        ...


@dataclass
class StreamState:
    """What the page shows about the stream."""

    running: bool = False
    period_ms: float = 0.0
    channels: tuple[str, ...] = ()
    received: int = 0
    lost: int = 0
    error: str = ""


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


class StreamSource:
    """Levels, edges, counters and analog values from the board's firmware-timed stream.

    ``analog_pins`` is called at every (re)start, so the channels follow the board's
    configuration (A4/A5 leave the stream when the I2C bus takes them).
    """

    def __init__(
        self,
        board: Board,
        analog_pins: Callable[[], Sequence[AnalogPin]],
        *,
        period_ms: float = 20.0,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        self.board = board
        self.period_ms = period_ms
        self.state = StreamState(period_ms=period_ms)
        self._analog_pins = analog_pins
        self._on_change = on_change
        self._pause_depth = 0
        self._wake = anyio.Event()
        self._stopped = anyio.Event()
        self._stopped.set()
        self._scope: anyio.CancelScope | None = None
        self._restart = False

    def describe(self) -> dict[str, object]:
        s = self.state
        return {
            "kind": "firmware-timed stream",
            "running": s.running,
            "period_ms": s.period_ms,
            "channels": list(s.channels),
            "received": s.received,
            "lost": s.lost,
            "error": s.error,
        }

    def restart(self) -> None:
        """Start the stream again with fresh parameters (e.g. after the I2C bus took A4/A5)."""
        self._restart = True
        if self._scope is not None:
            self._scope.cancel()
        self._wake.set()

    @asynccontextmanager
    async def paused(self) -> AsyncIterator[None]:
        """Stop the stream for the body (it is started again afterwards, also on errors)."""
        self._pause_depth += 1
        try:
            if self._scope is not None:
                self._scope.cancel()
            await self._stopped.wait()
            yield
        finally:
            self._pause_depth -= 1
            self._wake.set()

    def _should_stop(self) -> bool:
        return bool(self._pause_depth) or self._restart

    async def run(self, emit: Emit) -> None:
        while True:
            self._wake = anyio.Event()
            if self._pause_depth or not self.board.connected:
                with anyio.move_on_after(RETRY_INTERVAL):
                    await self._wake.wait()
                continue
            try:
                await self._stream_once(emit)
            except ArduinoIOError as exc:
                logger.info("monitor stream on %s stopped: %s", self.board, exc)
                self.state.error = str(exc)
                self._set_running(False)
                with anyio.move_on_after(RETRY_INTERVAL):
                    await self._wake.wait()

    async def _stream_once(self, emit: Emit) -> None:
        pins = tuple(self._analog_pins())
        clock = _Clock()
        self._restart = False
        self._stopped = anyio.Event()
        try:
            async with self.board.stream(
                analog=pins, levels=True, edges=True, counters=True, period_ms=self.period_ms
            ) as samples:
                # Only the reading is cancelled: a start or stop request cut in half would
                # leave the board streaming with nobody to stop it.
                with anyio.CancelScope() as scope:
                    self._scope = scope
                    if self._should_stop():  # asked while the start request was under way
                        scope.cancel()
                    self.state = StreamState(
                        period_ms=self.period_ms, channels=tuple(p.name for p in pins)
                    )
                    self._set_running(True)
                    async for sample in samples:
                        self.state.received = samples.received
                        self.state.lost = samples.lost
                        emit(activity_of(sample, clock.to_wall(sample.board_time_us)))
        finally:
            self._scope = None
            self._stopped.set()
            self._set_running(False)

    def _set_running(self, running: bool) -> None:
        if self.state.running != running:
            self.state.running = running
            self._on_change()
