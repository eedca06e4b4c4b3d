"""HC-SR04 style sonars: the :class:`Sonar` handle and its :class:`SonarReading`.

``sonar = await board.sonar(D7, D8)`` wires a ranger with its trigger on D7 and its echo
on D8 (any two digital pins).  The board fires its sonars itself, one at a time in slot
order so none hears another's ping (:mod:`arduinoio_async.protocol.commands.sonar`), and
times each echo from the pin-change interrupt's stamps of both edges; the host reads the
latest distance whenever it likes, or takes it in the stream (``board.stream(sonars=True)``).

"No echo" (nothing in range within the board's 30 ms) is its own answer: the distance
is ``None`` and :attr:`SonarReading.no_echo` is true, never an old or made-up distance.
Every reading carries its age, so a stale one is never taken for fresh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .. import protocol as p
from ..protocol.pins import DigitalPin
from .handles import PinHandle

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = [
    "Sonar",
    "SonarEcho",
    "SonarReading",
    "SonarSample",
    "sonar_block",
    "sonar_reading",
    "speed_of_sound",
]


def speed_of_sound(temperature_c: float) -> float:
    """The speed of sound in dry air at ``temperature_c``, in m/s (343.2 at 20 C)."""
    return 331.3 * math.sqrt(1.0 + temperature_c / 273.15)


@dataclass(frozen=True, slots=True)
class SonarReading:
    """A sonar's latest reading, as the board measured it."""

    #: Millimetres to the nearest echo; None if the last firing heard none (see
    #: :attr:`no_echo`) or the sonar has not fired yet.
    distance_mm: int | None
    #: The last firing heard no echo within the board's timeout (nothing in range).
    no_echo: bool
    #: The echo's width in microseconds (0 without a distance).
    echo_us: int
    #: Milliseconds since that reading (65535: that long or more, or none yet).
    age_ms: int
    #: Readings since the sonar was set up (16 bit, wrapping): a new one changes it.
    readings: int


@dataclass(frozen=True, slots=True)
class SonarSample:
    """One sonar slot's latest reading as a stream sample carries it."""

    #: Millimetres; None for "no echo" (:attr:`no_echo`), before the first reading, or a
    #: slot without a sonar.
    distance_mm: int | None
    no_echo: bool
    #: How old the reading was at the sampling instant, in milliseconds (the board counts
    #: 1.024 ms steps); None when 255 steps (261 ms) or older, or there is none.
    age_ms: float | None


def sonar_block(data: bytes) -> tuple[SonarSample, ...]:
    """The stream's sonar block (``p.split_sonar_block``) as samples, slot 0 first."""
    return tuple(
        SonarSample(
            None if distance in (p.SONAR_NO_ECHO, p.SONAR_NO_READING) else distance,
            distance == p.SONAR_NO_ECHO,
            None if age == 255 else age * 1.024,
        )
        for distance, age in p.split_sonar_block(data)
    )


def sonar_reading(reply: p.SonarReadReply) -> SonarReading:
    """The reading a SONAR READ reply carries."""
    distance = reply.distance_mm
    known = distance not in (p.SONAR_NO_ECHO, p.SONAR_NO_READING)
    return SonarReading(
        distance if known else None,
        distance == p.SONAR_NO_ECHO,
        reply.echo_us,
        reply.age_ms,
        reply.readings,
    )


class SonarEcho(PinHandle):
    """A sonar's echo pin: it holds its pin in :attr:`Board.roles` for the sonar."""

    ROLE = "sonar echo"

    def __init__(self, board: BoardCore, pin: DigitalPin, sonar: Sonar) -> None:
        super().__init__(board, pin)
        self.sonar = sonar

    async def release(self) -> None:
        """End the sonar (both pins)."""
        await self.sonar.release()


class Sonar(PinHandle):
    """An HC-SR04 style ranger fired by the board; :attr:`pin` is the trigger,
    :attr:`echo_pin` the echo."""

    ROLE = "sonar trigger"

    def __init__(self, board: BoardCore, trigger: DigitalPin, echo: DigitalPin, slot: int) -> None:
        super().__init__(board, trigger)
        self.echo_pin = echo
        self.slot = slot
        self.partner = SonarEcho(board, echo, self)

    def __repr__(self) -> str:
        return f"<Sonar {self.pin.name}/{self.echo_pin.name} slot {self.slot} on {self.board}>"

    @property
    def other_pins(self) -> tuple[DigitalPin, ...]:
        """The pins besides :attr:`pin` this role holds (released with it)."""
        return (self.echo_pin,)

    async def read(self) -> SonarReading:
        """The latest reading (distance, echo width, age, readings so far), from the board now."""
        self.check_usable()
        return sonar_reading(await self.board.request(p.SonarRead(self.slot)))

    async def distance_mm(self) -> int | None:
        """The latest distance in millimetres; None for "no echo" or before the first."""
        return (await self.read()).distance_mm

    async def release(self) -> None:
        """End the sonar on the board; both pins become free."""
        self.check_usable()
        await self.board.release(self.pin)
