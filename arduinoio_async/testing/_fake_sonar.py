"""The FakeBoard's sonars: ``firmware/src/sonar.c`` as a model, with the echo made up.

Mixed into :class:`~arduinoio_async.testing.FakeBoard` over the digital pins' model
(:mod:`._gpio`), since a sonar is two digital pins: a release of either pin ends the sonar
and frees both (as in the firmware) before the pin's own release.  There is no sound
here: a test puts an object in front of a sonar with :meth:`SonarModels.set_sonar`
(``None``: nothing in range), and every READ is a fresh firing at that distance, the
echo width and the millimetres computed as the firmware does (the speed of SONAR TIMING).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .. import protocol as p
from ..protocol.pins import Function, pin_mask
from ._gpio import GpioModels
from ._peripherals import PinModel, has

__all__ = ["SonarModels", "SonarSlot"]

E = p.ErrorCode
SONAR_PINS = pin_mask(Function.SONAR)


@dataclass
class SonarSlot:
    """One configured sonar, as sonar.c keeps it."""

    trigger: int
    echo: int
    distance_mm: int = p.SONAR_NO_READING
    echo_us: int = 0
    readings: int = 0


class SonarModels(GpioModels):
    """SONAR CONFIG/READ/TIMING (mixed into the FakeBoard)."""

    def _sonar_handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        """The SONAR class's request models, for the board's handler table."""
        return {
            p.SonarConfig: self._sonar_config,
            p.SonarRead: self._sonar_read,
            p.SonarTiming: self._sonar_timing,
        }

    def _release(self, request: p.PinRelease) -> p.Frame:
        for slot, sonar in list(self.sonars.items()):
            if request.pin in (sonar.trigger, sonar.echo):
                self._sonar_detach(slot)
        return super()._release(request)

    @property
    def sonars(self) -> dict[int, SonarSlot]:
        """Configured sonars by slot (for a test's assertions)."""
        if not hasattr(self, "_sonar_slots"):
            self._sonar_slots: dict[int, SonarSlot] = {}
            self._sonar_objects: dict[int, float | None] = {}
            self.sonar_speed_dm_s = p.SONAR_DEFAULT_SPEED_DM_S
            self.sonar_period_ms = 60
        return self._sonar_slots

    def set_sonar(self, trigger: int, distance_mm: float | None) -> None:
        """Put an object ``distance_mm`` in front of the sonar triggered on pin number
        ``trigger`` (None: nothing in range); its next reading says so."""
        self.sonars  # noqa: B018 (creates the state)
        self._sonar_objects[int(trigger)] = distance_mm

    def sonar_block(self) -> bytes:
        """The stream's sonar block: the slots up to the highest configured, each with its
        last reading and an age of 0 (the model fires at every read)."""
        count = max(self.sonars, default=-1) + 1
        block = bytes([count])
        for slot in range(count):
            sonar = self.sonars.get(slot)
            if sonar is not None:
                self._sonar_fire(sonar)
            distance = sonar.distance_mm if sonar else p.SONAR_NO_READING
            block += distance.to_bytes(2, "big") + bytes([0 if sonar else 255])
        return block

    def _sonar_detach(self, slot: int) -> None:
        old = self.sonars.pop(slot, None)
        if old is not None:
            self._pins[old.trigger] = PinModel()
            self._pins[old.echo] = PinModel()

    def _sonar_config(self, request: p.SonarConfig) -> p.Frame:
        slot, trigger, echo = request.slot, request.trigger, request.echo
        if slot >= p.SONAR_SLOTS or trigger == echo:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if not has(SONAR_PINS, trigger) or not has(SONAR_PINS, echo):
            return self._error(request, E.PIN_NOT_CAPABLE)
        own = self.sonars.get(slot)
        for pin in (trigger, echo):
            mine = own is not None and pin in (own.trigger, own.echo)
            if self._pins[pin].role != "free" and not mine:
                return self._error(request, E.PIN_BUSY)
        self._sonar_detach(slot)
        for pin in (trigger, echo):
            self._pins[pin].role = "sonar"
        self.sonars[slot] = SonarSlot(trigger, echo)
        return p.SonarConfigReply(slot, trigger, echo)

    def _sonar_fire(self, sonar: SonarSlot) -> None:
        if sonar.trigger not in self._sonar_objects:
            return  # nothing set up in front of it: no reading yet
        distance = self._sonar_objects[sonar.trigger]
        sonar.readings = (sonar.readings + 1) & 0xFFFF
        if distance is None or not 0 < distance <= 4000:
            sonar.distance_mm, sonar.echo_us = p.SONAR_NO_ECHO, 0
            return
        sonar.echo_us = round(distance * 20000 / self.sonar_speed_dm_s)
        sonar.distance_mm = (sonar.echo_us * self.sonar_speed_dm_s + 10000) // 20000

    def _sonar_read(self, request: p.SonarRead) -> p.Frame:
        if request.slot >= p.SONAR_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        sonar = self.sonars.get(request.slot)
        if sonar is None:
            return self._error(request, E.PIN_NOT_CONFIGURED)
        self._sonar_fire(sonar)
        age = 0 if sonar.readings else 0xFFFF
        return p.SonarReadReply(request.slot, sonar.distance_mm, sonar.echo_us, age, sonar.readings)

    def _sonar_timing(self, request: p.SonarTiming) -> p.Frame:
        if not request.period_ms or not 3000 <= request.speed_dm_s <= 4000:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        self.sonars  # noqa: B018 (creates the state)
        self.sonar_period_ms, self.sonar_speed_dm_s = request.period_ms, request.speed_dm_s
        return p.SonarTimingReply(request.period_ms, request.speed_dm_s)
