"""Input change events pushed by the board (protocol extension, docs/protocol.md 7.4).

A watched GPIO input reports each change its pin-change interrupt sees as a
:class:`~arduinoio_async.protocol.GpioChange` frame, so the host learns of an edge one
frame time after it happened instead of one round trip after it asked.  The rules:

* **Coalescing (board)**: the interrupt compares the levels with the levels it saw last;
  one event per changed pin and interrupt.  A pulse shorter than the interrupt's latency
  (a few microseconds) shows no change and is not reported; two pins changing together
  give two events with the same timestamp.
* **Overflow (board)**: an event that does not fit the transmit buffer is dropped; its
  sequence number is used up, so the host counts it in :attr:`ChangeStream.gaps`.  The
  sequence numbers count the events of all watched pins of the board together, so a gap
  names no pin: a consumer that needs every edge of one pin watches only that pin.
* **Overflow (host)**: when the consumer falls behind and ``buffer`` changes wait, the
  **oldest** is dropped (the newest level is the one that matters) and counted in
  :attr:`ChangeStream.dropped`.
* A callback (:meth:`Gpio.on_change <arduinoio_async.handles.Gpio.on_change>`) runs on the
  link's reader for each change; an exception in it is logged and never reaches the link.

The subscription ends with the ``watch`` block, a new configuration of the pin, its
release, or a reset of the board (a reconnect does not restore it).

Analog channels (:class:`AnalogChanges`, ``board.analog(A0).watch(deadband=...)``) follow
the same rules with their own sequence count: the board samples each watched channel from
its timer (every 0.5 ms x the number of watched channels) and reports a sample that moved
by **more than** ``deadband`` counts from the value it reported last, which becomes the
new reference.  Moves between two samples coalesce into one; a move within the deadband
never reports.  An event the transmit buffer had no room for is a sequence gap
(:attr:`AnalogChanges.gaps`); the board keeps the old reference, so the next sample
reports the move again.  While a channel is watched the ADC is the watch's: a stream
with analog channels is refused (and a watch while one runs), with PIN_BUSY.
"""

from __future__ import annotations

import collections
import contextlib
import time
import weakref
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import anyio

from . import protocol as p
from ._event_queue import EventQueue, SequencedQueue
from .errors import ArduinoIOError, BoardError, UsageError, ValueRangeError
from .transport import Transport

if TYPE_CHECKING:
    from .board import Board
    from .protocol.pins import AnalogPin, DigitalPin

__all__ = [
    "DEFAULT_CHANGE_BUFFER",
    "AnalogChanges",
    "AnalogMove",
    "Change",
    "ChangeStream",
    "CountReports",
    "watch_analog",
    "watch_changes",
    "watch_counter",
]

DEFAULT_CHANGE_BUFFER = 1000


@dataclass(frozen=True, slots=True)
class Change:
    """One change of a watched input, as its pin-change interrupt saw it."""

    pin: int
    #: The level after the change: True after a rising edge, False after a falling one.
    level: bool
    #: The board's sequence number of the event (all watched pins share the count).
    sequence: int
    #: The board's microsecond clock when the interrupt ran (wraps after 71 minutes).
    board_time_us: int
    #: ``time.monotonic()`` when the frame was decoded on the host.
    host_time: float

    @property
    def rose(self) -> bool:
        return self.level

    @property
    def fell(self) -> bool:
        return not self.level

    @classmethod
    def from_event(cls, event: p.GpioChange, host_time: float) -> Change:
        return cls(event.pin, event.level, event.sequence, event.timestamp_us, host_time)


class ChangeStream(SequencedQueue[Change]):
    """Async iterator over the changes of one pin (see the module docstring for the rules).

    With ``callback`` the changes go to it instead of the buffer.
    """

    WHAT = "changes"

    def __init__(
        self,
        link: Transport,
        pin: int,
        buffer: int = DEFAULT_CHANGE_BUFFER,
        callback: Callable[[Change], None] | None = None,
    ) -> None:
        self.pin = pin
        super().__init__(link, buffer, callback)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.GpioChange):
            return
        self._count_gap(event.sequence)  # the count is shared by every watched pin
        if event.pin == self.pin:
            self._deliver(Change.from_event(event, time.monotonic()))


async def _end_watch(link: Transport, stop: p.Request[Any] | None, queue: EventQueue[Any]) -> None:
    """Send ``stop`` (None: other watchers keep the board's subscription) and detach.

    Shielded, so a cancelled block still unsubscribes; a failure means the link is gone or
    the pin was reconfigured, and nothing is watched any more either way.
    """
    try:
        if stop is not None:
            with anyio.CancelScope(shield=True), contextlib.suppress(ArduinoIOError):
                await link.request(stop)
    finally:
        queue.detach()


@asynccontextmanager
async def watch_changes(
    board: Board,
    pin: DigitalPin,
    buffer: int = DEFAULT_CHANGE_BUFFER,
    callback: Callable[[Change], None] | None = None,
) -> AsyncIterator[ChangeStream]:
    """Subscribe ``pin`` (already a GPIO input) for the block; unsubscribe after it."""
    link = board.link
    stream = ChangeStream(link, pin, buffer, callback)
    watchers = _watchers.setdefault(board, collections.Counter())
    watchers[pin] += 1  # the board's subscription ends with the last watcher of the pin
    try:
        await board.request(p.GpioWatch(pin, True))
        yield stream
    finally:
        watchers[pin] -= 1
        await _end_watch(link, p.GpioWatch(pin, False) if not watchers[pin] else None, stream)


#: Watchers per board and pin, so that one block's end keeps the others' subscription.
_watchers: weakref.WeakKeyDictionary[Board, collections.Counter[int]] = weakref.WeakKeyDictionary()


class CountReports(EventQueue[p.CounterReport]):
    """Async iterator over a watched counter's reports (``CounterReport`` events).

    A report the board could not send shows as a count that advanced by more than
    ``every``: :attr:`missed` counts those reports; a full buffer drops the oldest
    (:attr:`dropped`).
    """

    WHAT = "a counter"

    def __init__(self, link: Transport, pin: int, every: int, buffer: int) -> None:
        self.pin = pin
        self.every = every
        self.missed = 0
        self._last: int | None = None
        super().__init__(link, buffer)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.CounterReport) or event.pin != self.pin:
            return
        if self._last is not None:
            advanced = (event.count - self._last) & 0xFFFFFFFF
            self.missed += max(0, advanced // self.every - 1)
        self._last = event.count
        self._put(event)


@asynccontextmanager
async def watch_counter(
    board: Board, pin: DigitalPin, every: int, buffer: int = DEFAULT_CHANGE_BUFFER
) -> AsyncIterator[CountReports]:
    """Reports of counter ``pin`` every ``every`` counts for the block."""
    if not 1 <= every <= 0xFFFF:
        raise ValueRangeError("counter report interval (counts)", every, "1-65535")
    link = board.link
    reports = CountReports(link, pin, every, buffer)
    try:
        await board.request(p.CounterWatch(pin, every))
        yield reports
    finally:
        await _end_watch(link, p.CounterWatch(pin, 0), reports)


@dataclass(frozen=True, slots=True)
class AnalogMove:
    """A watched analog channel moved past its deadband."""

    channel: int
    #: The new value (0-1023), now the reference the next move is measured from.
    value: int
    #: The board's sequence number (all watched channels share the count).
    sequence: int
    #: The board's microsecond clock when the conversion ended (wraps after 71 minutes).
    board_time_us: int
    #: ``time.monotonic()`` when the frame was decoded on the host.
    host_time: float


class AnalogChanges(SequencedQueue[AnalogMove]):
    """Async iterator over the moves of one analog channel (module docstring: the rules).

    :attr:`baseline` is the value the board measured as the watch began; with
    ``callback`` the moves go to it instead of the buffer.
    """

    WHAT = "analog changes"

    def __init__(
        self,
        link: Transport,
        channel: int,
        buffer: int = DEFAULT_CHANGE_BUFFER,
        callback: Callable[[AnalogMove], None] | None = None,
    ) -> None:
        self.channel = channel
        self.baseline: int | None = None
        super().__init__(link, buffer, callback)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.AnalogChange):
            return
        self._count_gap(event.sequence)  # the count is shared by every watched channel
        if event.channel == self.channel:
            self._deliver(
                AnalogMove(
                    event.channel, event.value, event.sequence, event.timestamp_us, time.monotonic()
                )
            )


#: Watchers per board and channel with their deadband: blocks that agree share the board's
#: watch, and the last one to end stops it.
_analog_watchers: weakref.WeakKeyDictionary[Board, dict[int, tuple[int, int]]] = (
    weakref.WeakKeyDictionary()
)


@asynccontextmanager
async def watch_analog(
    board: Board,
    channel: AnalogPin,
    deadband: int,
    buffer: int = DEFAULT_CHANGE_BUFFER,
    callback: Callable[[AnalogMove], None] | None = None,
) -> AsyncIterator[AnalogChanges]:
    """Moves of ``channel`` by more than ``deadband`` counts for the block."""
    if not 1 <= deadband <= p.ANALOG_MAX:
        raise ValueRangeError("analog deadband (ADC counts)", deadband, f"1-{p.ANALOG_MAX}")
    watchers = _analog_watchers.setdefault(board, {})
    count, watched_band = watchers.get(channel, (0, deadband))
    if watched_band != deadband:
        raise UsageError(
            f"{channel.name} is already watched with deadband {watched_band} on {board}: "
            f"one deadband per channel (end that watch or use the same deadband)"
        )
    link = board.link
    stream = AnalogChanges(link, channel, buffer, callback)
    watchers[channel] = (count + 1, deadband)
    try:
        try:
            reply = await board.request(p.AnalogWatch(channel, deadband))
        except BoardError as exc:
            if getattr(exc.code, "name", "") != "PIN_BUSY":
                raise
            raise BoardError(
                exc.code,
                exc.request,
                "the ADC belongs to a running stream with analog channels (stop it first), "
                "or A4/A5 to the I2C bus",
            ) from exc
        stream.baseline = reply.value
        yield stream
    finally:
        left = watchers[channel][0] - 1
        if left:
            watchers[channel] = (left, deadband)
        else:
            del watchers[channel]
        await _end_watch(link, p.AnalogWatch(channel, 0) if not left else None, stream)
