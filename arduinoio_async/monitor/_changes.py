"""Levels and edges of the digital inputs, pushed by the board as change events.

Every pin with an input role is subscribed to the board's change events
(:func:`arduinoio_async.board.changes.watch_changes`, protocol extension 7.4): the board sends
each edge its pin-change interrupt sees, with the level after it and a sequence number.
The page so counts *every* edge (a stream sample can only say "rose and/or fell since the
previous sample") and shows the events the sequence numbers say were lost.  Nothing is
polled for what the events deliver: one read per subscription gives the starting level,
then only events change it.

The subscriptions follow the board (:class:`~._sources.SubscribingSource`):

* a new set of inputs (a role changed on the page or in a program that embeds the
  monitor), a board that was reset (its session tag changed: the library's restore
  subscribes the watches again, but the edges between the reset and the restore are
  unknown, so each level must be read afresh) or a new link (replug, a remote board that
  came back): every input is subscribed again and its level read again.
* the source's end (the monitor stops) unsubscribes every pin; a user's own watch of the
  same pin keeps its subscription (``watch_changes`` counts the watchers).

Edges that happen while the inputs are being subscribed again are not counted (the level
is read again afterwards); the page's role control therefore answers only once the new
inputs are watched (:meth:`ChangeSource.wait_watching`), so an edge after its answer
counts.  The sequence numbers count the events of all watched pins of a board
together, so a loss names no pin: the page shows it per board.  Reading the starting
level with ``GpioRead`` clears the edges the board latched for that pin, which a program
embedding the monitor and relying on ``DigitalInput.read()``'s edges would see.

A board whose firmware does not announce change events (``Feature.GPIO_CHANGES``) gets
none: the page says so, and its inputs show the stream's levels instead.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from contextlib import AsyncExitStack
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import anyio

from .. import protocol as p
from ..board.changes import Change, ChangeStream, watch_changes
from ..protocol.pins import DigitalPin
from ._sources import Activity, Emit, PinKey, SubscribingSource

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["ChangeSource", "ChangeState"]

logger = logging.getLogger(__name__)


@dataclass
class ChangeState:
    """What the page shows about the change events."""

    pins: tuple[str, ...] = ()
    received: int = 0
    #: Subscriptions made so far (the first, and one after each role change or reset).
    subscriptions: int = 0


class ChangeSource(SubscribingSource):
    """Each digital input's level and edges from the board's change events.

    ``inputs`` is called at every (re)start and supervision check: the pins to watch,
    each with a key that changes when the pin is configured again.
    """

    def __init__(
        self,
        board: Board,
        inputs: Callable[[], Mapping[DigitalPin, PinKey]],
        *,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        super().__init__(board, inputs, on_change=on_change)
        self.state = ChangeState()
        #: Pins whose level and edges come from change events now.
        self.watched: frozenset[DigitalPin] = frozenset()
        self._lost_before = 0
        self._gap_counter: ChangeStream | None = None
        self._seen = dict.fromkeys(DigitalPin, 0)  # any model's pins (a Mega's D53 too)
        self._watching = anyio.Event()

    async def wait_watching(self, pins: frozenset[DigitalPin]) -> None:
        """Return once exactly ``pins`` are watched (at once when change events are not
        supported: nothing would ever be watched)."""
        while self.supported and self.watched != pins:
            await self._watching.wait()

    @property
    def supported(self) -> bool:
        """Whether the board's firmware announces change events."""
        return bool(self.board.capabilities.features & p.Feature.GPIO_CHANGES)

    @property
    def watched_mask(self) -> int:
        return sum(1 << int(pin) for pin in self.watched)

    @property
    def lost(self) -> int:
        """Events the board's sequence numbers say never arrived, over every subscription.

        The first stream of a subscription sees every change event the board sends
        while it lasts (each stream counts the gaps of all pins): its gaps are the
        board's.
        """
        current = self._gap_counter.gaps if self._gap_counter is not None else 0
        return self._lost_before + current

    def describe(self) -> dict[str, object]:
        error = self.error
        if not self.supported:
            error = "not in this firmware (inputs show the stream's levels)"
        return {
            "kind": "change events",
            "running": self.running,
            "supported": self.supported,
            "pins": list(self.state.pins),
            "received": self.state.received,
            "lost": self.lost,
            "error": error,
        }

    def _available(self) -> bool:
        return super()._available() and self.supported

    async def _run_once(self, emit: Emit) -> None:
        board = self.board
        link = board.link
        epoch = self._epoch()
        pins = sorted(epoch[2])
        try:
            async with AsyncExitStack() as stack:
                for pin in pins:
                    callback = partial(self._changed, emit)
                    # Not cancelled halfway: the board would watch a pin nobody follows.
                    with anyio.CancelScope(shield=True):
                        stream = await stack.enter_async_context(
                            watch_changes(board, pin, callback=callback)
                        )
                    if self._gap_counter is None:
                        self._gap_counter = stream
                self.state.pins = tuple(pin.name for pin in pins)
                with self._cancellable():
                    for pin in pins:
                        await self._read_level(pin, emit)
                    self.watched = frozenset(pins)
                    watching, self._watching = self._watching, anyio.Event()
                    watching.set()
                    self.state.subscriptions += 1
                    self._on_change()
                    await self._while_current(link, epoch)
        finally:
            # Also when a pin's subscription failed: the next one counts from here.
            self.watched = frozenset()
            self._lost_before = self.lost
            self._gap_counter = None

    async def _read_level(self, pin: DigitalPin, emit: Emit) -> None:
        """The starting level of a just-subscribed pin.

        An event that arrives while the read is under way carries a level at least as
        new as the read's, or is followed by another event: the read is then dropped.
        """
        before = self._seen[pin]
        reply = await self.board.request(p.GpioRead(pin))
        if self._seen[pin] == before:
            emit(Activity(time=time.time(), pin_levels={pin: reply.level}))

    def _changed(self, emit: Emit, change: Change) -> None:
        """One change event, on the link's reader: fold it into an activity at once."""
        pin = DigitalPin(change.pin)
        self._seen[pin] += 1
        self.state.received += 1
        bit = 1 << change.pin
        emit(
            Activity(
                time=time.time() - (time.monotonic() - change.host_time),
                pin_levels={pin: change.level},
                rose=bit if change.level else 0,
                fell=0 if change.level else bit,
            )
        )
