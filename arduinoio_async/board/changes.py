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
* A callback (:meth:`Gpio.on_change <arduinoio_async.board.handles.Gpio.on_change>`) runs on the
  link's reader for each change; an exception in it is logged and never reaches the link.

The subscription ends with the ``watch`` block, a new configuration of the pin or its
release.  **A reset of the board** (power loss, watchdog, brown-out, ``board.reset()``)
forgets it on the board; the restore after the reset (the manager's, or
``board.restore()`` / ``board.reset(restore=True)``) subscribes it again after the pin
roles, and the ``async for`` goes on (:mod:`arduinoio_async.board.watches`):

* the board numbers its events from 0 again after a boot: the queue starts its count
  afresh, so the restart is no gap; ``restarts`` counts the resets the watch lived
  through, and the changes between the reset and the restore are unknown (the board was
  not watching) and in no count: read the pin after a restart if its level matters;
* a counter counts from 0 again (its reports too: no report counts as ``missed``); an
  analog watch takes the restore's measurement as its new :attr:`AnalogChanges.baseline`;
* a watch the board refuses to restore (the pin has another role now, or none) ends its
  iterator with :class:`~arduinoio_async.errors.WatchLostError` after the buffered
  items; a callback watch logs it and its block raises it when it ends;
* a replug (a new link) ends the watch with
  :class:`~arduinoio_async.errors.BoardDisconnectedError`, as the link it listened to
  is gone: start it again on the re-attached board.

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

import contextlib
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

from .. import protocol as p
from .._event_queue import EventQueue, SequencedQueue
from ..errors import BoardError, ValueRangeError
from ..transport import Transport

if TYPE_CHECKING:
    from ..protocol.pins import AnalogPin, DigitalPin
    from ._core import BoardCore

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
        """True for a rising edge (the pin went high)."""
        return self.level

    @property
    def fell(self) -> bool:
        """True for a falling edge (the pin went low)."""
        return not self.level

    @classmethod
    def from_event(cls, event: p.GpioChange, host_time: float) -> Change:
        """The change a ``GpioChange`` event reports, received at ``host_time``."""
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


def _name(pin: int) -> str:
    return str(getattr(pin, "name", f"D{pin}"))


@asynccontextmanager
async def watch_changes(
    board: BoardCore,
    pin: DigitalPin,
    buffer: int = DEFAULT_CHANGE_BUFFER,
    callback: Callable[[Change], None] | None = None,
) -> AsyncIterator[ChangeStream]:
    """Subscribe ``pin`` (already a GPIO input) for the block; the last block watching the
    pin unsubscribes it.  Restored after a reset (:mod:`arduinoio_async.board.watches`);
    a watch the board refuses to restore raises WatchLostError when its block ends."""
    stream = ChangeStream(board.link, pin, buffer, callback)
    async with board.watches.subscribe(
        ("gpio", int(pin)),
        p.GpioWatch(pin, True),
        p.GpioWatch(pin, False),
        stream,
        conflict=lambda held: f"{_name(pin)} is already watched as {held}",
    ):
        yield stream
    stream.raise_unreported()


T = TypeVar("T")


class IntervalReports(EventQueue[T]):
    """Reports the board pushes every ``every`` counts (a counter's, an encoder's).

    A report the board could not send shows as a count that moved by more than ``every``
    since the previous one: :attr:`missed` counts those reports; a full buffer drops the
    oldest (:attr:`dropped`).  A replayed set-up (after a reset, too) starts the count at
    0 again, so the next report is compared with nothing and none counts as missed.
    """

    def __init__(self, link: Transport, every: int, buffer: int) -> None:
        self.every = every
        self.missed = 0
        self._last: int | None = None
        super().__init__(link, buffer)

    def resubscribing(self) -> None:
        """The set-up is replayed: the next report is compared with nothing."""
        self._last = None

    def _note_count(self, count: int, moved: Callable[[int, int], int]) -> None:
        """Account the report of ``count``; ``moved(count, last)`` is how far it went."""
        if self._last is not None:
            self.missed += max(0, moved(count, self._last) // self.every - 1)
        self._last = count


class CountReports(IntervalReports[p.CounterReport]):
    """Async iterator over a watched counter's reports (``CounterReport`` events); see
    :class:`IntervalReports` for :attr:`missed` and :attr:`dropped`."""

    WHAT = "a counter"

    def __init__(self, link: Transport, pin: int, every: int, buffer: int) -> None:
        self.pin = pin
        super().__init__(link, every, buffer)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.CounterReport) or event.pin != self.pin:
            return
        self._note_count(event.count, lambda count, last: (count - last) & 0xFFFFFFFF)
        self._put(event)


@asynccontextmanager
async def watch_counter(
    board: BoardCore, pin: DigitalPin, every: int, buffer: int = DEFAULT_CHANGE_BUFFER
) -> AsyncIterator[CountReports]:
    """Reports of counter ``pin`` every ``every`` counts for the block."""
    if not 1 <= every <= 0xFFFF:
        raise ValueRangeError("counter report interval (counts)", every, "1-65535")
    reports = CountReports(board.link, pin, every, buffer)
    async with board.watches.subscribe(
        ("counter", int(pin)),
        p.CounterWatch(pin, every),
        p.CounterWatch(pin, 0),
        reports,
        conflict=lambda held: (
            f"{_name(pin)} already reports every {getattr(held, 'every', '?')} counts on "
            f"{board}: one interval per counter (end that block or use the same interval)"
        ),
    ):
        yield reports
    reports.raise_unreported()


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

    def restored(self, reply: p.Reply) -> None:
        """The board measured a new baseline when the watch was subscribed again."""
        if isinstance(reply, p.AnalogWatchReply):
            self.baseline = reply.value

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


@asynccontextmanager
async def watch_analog(
    board: BoardCore,
    channel: AnalogPin,
    deadband: int,
    buffer: int = DEFAULT_CHANGE_BUFFER,
    callback: Callable[[AnalogMove], None] | None = None,
) -> AsyncIterator[AnalogChanges]:
    """Moves of ``channel`` by more than ``deadband`` counts for the block.

    Blocks that agree on the deadband share the board's watch, and the last one to end
    stops it; restored after a reset like every watch."""
    if not 1 <= deadband <= p.ANALOG_MAX:
        raise ValueRangeError("analog deadband (ADC counts)", deadband, f"1-{p.ANALOG_MAX}")
    stream = AnalogChanges(board.link, channel, buffer, callback)
    subscription = board.watches.subscribe(
        ("analog", int(channel)),
        p.AnalogWatch(channel, deadband),
        p.AnalogWatch(channel, 0),
        stream,
        conflict=lambda held: (
            f"{channel.name} is already watched with deadband {getattr(held, 'deadband', '?')} "
            f"on {board}: one deadband per channel (end that watch or use the same deadband)"
        ),
    )
    try:
        reply = await subscription.__aenter__()
    except BoardError as exc:
        if getattr(exc.code, "name", "") != "PIN_BUSY":
            raise
        raise BoardError(
            exc.code,
            exc.request,
            "the ADC belongs to a running stream with analog channels (stop it first), "
            "or A4/A5 to the I2C bus",
        ) from exc
    async with contextlib.AsyncExitStack() as stack:
        stack.push_async_exit(subscription)
        stream.baseline = reply.value
        yield stream
    stream.raise_unreported()
