"""The FakeBoard's quadrature encoders: ``firmware/src/encoder.c`` as a model.

Mixed into :class:`~arduinoio_async.testing.FakeBoard` over the digital pins' model
(:mod:`._gpio`), since an encoder is two digital pins: a release of either pin ends the
encoder and frees both (as in the firmware) before the pin's own release.
The board's ``drive()`` calls :meth:`EncoderModels._encoder_edge` for every level change, so
a test turns an encoder by driving its two pins, exactly as the firmware's interrupt sees
them (one change at a time; a test that wants an invalid transition sets ``levels`` of one
pin directly and drives the other).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import anyio

from .. import protocol as p
from ..protocol.pins import Function
from ._gpio import GpioModels
from ._peripherals import PinModel, has

__all__ = ["EncoderModels", "EncoderSlot"]

E = p.ErrorCode

#: Counting positions per mode: a step into one of these going forward (or out of it
#: going back) changes the count (encoder.c's ``steps``).
_STEPS = {p.EncoderMode.X4: (0, 1, 2, 3), p.EncoderMode.X2: (1, 3), p.EncoderMode.X1: (1,)}


def _position(a: bool, b: bool) -> int:
    """AB = 00 -> 0, 10 -> 1, 11 -> 2, 01 -> 3 (A leads B going forward)."""
    gray = (b << 1) | a
    return gray ^ (gray >> 1)


@dataclass
class EncoderSlot:
    """One configured encoder, as encoder.c keeps it."""

    pin_a: int
    pin_b: int
    mode: p.EncoderMode
    position: int
    count: int = 0
    invalid: int = 0
    edge_us: int = 0
    direction: int = 1
    every: int = 0
    since: int = 0

    def step(self, position: int, now_us: int) -> bool:
        """Decode a move to ``position``; True when the count changed."""
        prev, steps = self.position, _STEPS[self.mode]
        delta = 0
        move = (position - prev) & 3
        if move == 0:
            return False
        if move == 1:
            self.direction = 1
            delta = int(position in steps)
        elif move == 3:
            self.direction = -1
            delta = -int(prev in steps)
        else:  # a skipped state: two positions the last direction's way
            self.invalid = (self.invalid + 1) & 0xFFFF
            if self.direction > 0:
                delta = int((prev + 1) & 3 in steps) + int(position in steps)
            else:
                delta = -(int(prev in steps) + int((prev + 3) & 3 in steps))
        self.position = position
        if not delta:
            return False
        self.count = ((self.count + delta + 2**31) & 0xFFFFFFFF) - 2**31
        self.edge_us = now_us & 0xFFFFFFFF
        self.since += abs(delta)
        return True


class EncoderModels(GpioModels):
    """ENCODER CONFIG/READ/PRESET/WATCH and the reports (mixed into the FakeBoard)."""

    def _encoder_handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        """The ENCODER class's request models, for the board's handler table."""
        return {
            p.EncoderConfig: self._encoder_config,
            p.EncoderRead: self._encoder_read,
            p.EncoderPreset: self._encoder_preset,
            p.EncoderWatch: self._encoder_watch,
        }

    def _release(self, request: p.PinRelease) -> p.Frame:
        self._encoder_release(request.pin)
        return super()._release(request)

    @property
    def encoders(self) -> dict[int, EncoderSlot]:
        """Configured encoders by slot (for a test's assertions)."""
        if not hasattr(self, "_encoder_slots"):
            self._encoder_slots: dict[int, EncoderSlot] = {}
        return self._encoder_slots

    def _board_us(self) -> int:
        return int((anyio.current_time() - self._booted) * 1_000_000) & 0xFFFFFFFF

    def encoder_counts(self) -> tuple[int, ...]:
        """The stream's ENCODERS values: each slot's count, 0 for a free slot."""
        return tuple(
            self.encoders[s].count if s in self.encoders else 0 for s in range(p.ENCODER_SLOTS)
        )

    def _encoder_detach(self, slot: int) -> None:
        old = self.encoders.pop(slot, None)
        if old is not None:
            self._pins[old.pin_a] = PinModel()
            self._pins[old.pin_b] = PinModel()

    def _encoder_release(self, pin: int) -> None:
        """A pin release of either pin ends the encoder (both pins free)."""
        for slot, enc in list(self.encoders.items()):
            if pin in (enc.pin_a, enc.pin_b):
                self._encoder_detach(slot)

    def _encoder_config(self, request: p.EncoderConfig) -> p.Frame:
        slot, a, b = request.slot, request.pin_a, request.pin_b
        if slot >= p.ENCODER_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if not has(self._mask(Function.ENCODER), a) or not has(self._mask(Function.ENCODER), b):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if a == b or int(request.mode) not in (1, 2, 4):
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        own = self.encoders.get(slot)
        for pin in (a, b):
            mine = own is not None and pin in (own.pin_a, own.pin_b)
            if self._pins[pin].role != "free" and not mine:
                return self._error(request, E.PIN_BUSY)
        self._encoder_detach(slot)
        for pin in (a, b):
            self._pins[pin].role = "encoder"
            self._pins[pin].pull_up = True
        position = _position(self.levels[a], self.levels[b])
        self.encoders[slot] = EncoderSlot(a, b, p.EncoderMode(request.mode), position)
        return p.EncoderConfigReply(slot, a, b, request.mode)

    def _encoder_slot(self, request: Any) -> EncoderSlot | p.Frame:
        if request.slot >= p.ENCODER_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        enc = self.encoders.get(request.slot)
        if enc is None:
            return self._error(request, E.PIN_NOT_CONFIGURED)
        return enc

    def _encoder_read(self, request: p.EncoderRead) -> p.Frame:
        enc = self._encoder_slot(request)
        if not isinstance(enc, EncoderSlot):
            return enc
        return p.EncoderReadReply(request.slot, enc.count, enc.invalid, enc.edge_us)

    def _encoder_preset(self, request: p.EncoderPreset) -> p.Frame:
        enc = self._encoder_slot(request)
        if not isinstance(enc, EncoderSlot):
            return enc
        reply = p.EncoderPresetReply(
            request.slot, request.value, enc.count, enc.invalid, enc.edge_us
        )
        enc.count, enc.invalid, enc.since = request.value, 0, 0
        return reply

    def _encoder_watch(self, request: p.EncoderWatch) -> p.Frame:
        enc = self._encoder_slot(request)
        if not isinstance(enc, EncoderSlot):
            return enc
        enc.every, enc.since = request.every, 0
        return p.EncoderWatchReply(request.slot, request.every)

    def _encoder_edge(self, pin: int) -> None:
        """``pin`` changed level: every encoder on it decodes (and may report)."""
        for slot, enc in self.encoders.items():
            if pin not in (enc.pin_a, enc.pin_b):
                continue
            now = self._board_us()
            position = _position(self.levels[enc.pin_a], self.levels[enc.pin_b])
            if not enc.step(position, now) or not enc.every or enc.since < enc.every:
                continue
            enc.since = 0
            report = p.EncoderReport(slot, enc.count, enc.invalid, enc.edge_us)
            try:
                self._changes_in.send_nowait(report)
            except anyio.WouldBlock:
                self.changes_dropped += 1
