"""The FakeBoard's RC pulse-width inputs: ``firmware/src/pulse_in.c`` as a model.

Mixed into :class:`~arduinoio_async.testing.FakeBoard` over the digital pins' model
(:mod:`._gpio`): a slot holds one pin in the role ``pulse-input``; a release of the pin
ends it.  The board's ``drive()`` calls :meth:`PulseInModels._pulse_in_edge` for every
level change, so two drives time a pulse with the fake's clock; :meth:`rc_pulse` gives a
slot a pulse of an exact width ending now (a test's receiver).  As in the firmware, a slot
starts lost, its first pulse sends a PulseInSignal "back" event, and it is lost again
``timeout_ms`` after its last pulse ended (the model finds that when it is read; it sends
no "lost" event by itself).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import anyio

from .. import protocol as p
from ..protocol.pins import Function, pin_mask
from ._gpio import GpioModels
from ._peripherals import PinModel, has

__all__ = ["PulseInModels", "PulseInSlot"]

E = p.ErrorCode
PULSE_IN_PINS = pin_mask(Function.PULSE_IN)
AGE_MAX = 0xFFFF


@dataclass
class PulseInSlot:
    """One configured pulse input, as pulse_in.c keeps it (times in board us)."""

    pin: int
    timeout_ms: int
    width_us: int = 0
    end_us: int | None = None  # when the last pulse ended; None: none yet
    rise_us: int | None = None  # the pulse under way rose then
    lost: bool = True


class PulseInModels(GpioModels):
    """PULSE_IN CONFIG/READ and the "back" event (mixed into the FakeBoard)."""

    def _board_us(self) -> int:
        raise NotImplementedError  # the FakeBoard's clock (EncoderModels)

    def _pulse_in_handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        """The PULSE_IN class's request models, for the board's handler table."""
        return {p.PulseInConfig: self._pulse_in_config, p.PulseInRead: self._pulse_in_read}

    @property
    def pulse_inputs(self) -> dict[int, PulseInSlot]:
        """Configured pulse inputs by slot (for a test's assertions)."""
        if not hasattr(self, "_pulse_in_slots"):
            self._pulse_in_slots: dict[int, PulseInSlot] = {}
        return self._pulse_in_slots

    def _release(self, request: p.PinRelease) -> p.Frame:
        self._pulse_in_release(request.pin)
        return super()._release(request)

    def _pulse_in_release(self, pin: int) -> None:
        for slot, held in list(self.pulse_inputs.items()):
            if held.pin == pin:
                del self.pulse_inputs[slot]
                self._pins[pin] = PinModel()

    def rc_pulse(self, pin: int, width_us: int) -> None:
        """A complete high pulse of ``width_us`` on ``pin``, ending now (a receiver's)."""
        for slot, held in self.pulse_inputs.items():
            if held.pin == pin:
                self._pulse_in_ended(slot, held, width_us, self._board_us())

    def _pulse_in_edge(self, pin: int, level: bool) -> None:
        """``pin`` changed level: a rise starts a pulse, a fall after a rise ends it."""
        now = self._board_us()
        for slot, held in self.pulse_inputs.items():
            if held.pin != pin:
                continue
            if level:
                held.rise_us = now
            elif held.rise_us is not None:
                self._pulse_in_ended(slot, held, (now - held.rise_us) & 0xFFFFFFFF, now)
                held.rise_us = None

    def _pulse_in_ended(self, slot: int, held: PulseInSlot, width_us: int, now: int) -> None:
        held.width_us, held.end_us = min(width_us, 0xFFFF), now
        if held.lost:
            held.lost = False
            try:
                self._changes_in.send_nowait(p.PulseInSignal(slot, held.width_us, 0, 0))
            except anyio.WouldBlock:
                self.changes_dropped += 1

    def _pulse_in_config(self, request: p.PulseInConfig) -> p.Frame:
        slot, pin = request.slot, request.pin
        if slot >= p.PULSE_IN_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if not has(PULSE_IN_PINS, pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if not request.timeout_ms:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        own = self.pulse_inputs.get(slot)
        if self._pins[pin].role != "free" and (own is None or own.pin != pin):
            return self._error(request, E.PIN_BUSY)
        if own is not None:
            self._pulse_in_release(own.pin)
        self._pins[pin].role = "pulse-input"
        self.pulse_inputs[slot] = PulseInSlot(pin, request.timeout_ms)
        return p.PulseInConfigReply(slot, pin, request.timeout_ms)

    def _pulse_in_read(self, request: p.PulseInRead) -> p.Frame:
        if request.slot >= p.PULSE_IN_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        held = self.pulse_inputs.get(request.slot)
        if held is None:
            return self._error(request, E.PIN_NOT_CONFIGURED)
        if held.end_us is None:
            age = AGE_MAX
        else:
            age = min(((self._board_us() - held.end_us) & 0xFFFFFFFF) // 1000, AGE_MAX)
            if age >= held.timeout_ms:
                held.lost = True
        return p.PulseInReadReply(request.slot, held.width_us, age, int(held.lost))
