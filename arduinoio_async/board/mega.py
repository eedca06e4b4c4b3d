"""A board typed for the Arduino Mega 2560: mypy checks its pins as ``Board``'s the Uno's.

``Board``'s handle methods take the Uno's pin types (``ServoPin`` is D9/D10, ...), so mypy
refuses ``board.servo(D2)`` before the program runs.  A Mega's timers reach other pins,
so ``Mega2560Board`` takes the Mega's (``protocol.pins_mega``): open it as
``async with Mega2560Board.open(port) as mega:`` and ``mega.servo(D44)`` type-checks while
``mega.servo(D9)`` (Timer2 keeps the Mega's tick) does not.  At run time it is a
``Board``: every pin is checked against what the board described (and the open fails
unless the board says it is a Mega 2560, so the types cannot lie).

The servo, software PWM and duty PWM overrides take pin sets that do not contain the Uno's
(D9/D10 are no servo pins on a Mega), which mypy calls an incompatible override: a Mega is
not an Uno there, and code typed for any ``Board`` gets the run-time check.  The counter
and SPI pins only widen the Uno's.
"""

from __future__ import annotations

from typing import cast

from .. import protocol as p
from ..errors import UsageError
from ..protocol.boards import MEGA2560
from ..protocol.pins import CounterPin, DutyPwmPin, ServoPin, SoftPwmPin, SpiCsPin
from ..protocol.pins_mega import (
    MegaCounterPin,
    MegaDutyPwmPin,
    MegaServoPin,
    MegaSoftPwmPin,
    MegaSpiCsPin,
)
from ..transport import Transport
from .board import Board
from .handles import Counter, Servo, SoftPwm
from .motors import DutyPwm
from .spi import BitOrderName, SpiBus

__all__ = ["Mega2560Board", "WrongBoardModelError"]


class WrongBoardModelError(UsageError):
    """A board class for one model was opened on a board that described another."""

    def __init__(self, port: str, found: str, expected: str) -> None:
        self.found = found
        self.expected = expected
        super().__init__(
            f"the board on {port} is an {found}, not an {expected}: open it with Board"
        )


class Mega2560Board(Board):
    """A connected Arduino Mega 2560 (the board must describe itself as one)."""

    async def _handshake(self, link: Transport) -> None:
        await super()._handshake(link)
        if self.model.model_id != MEGA2560.model_id:
            raise WrongBoardModelError(link.name, self.model.name, MEGA2560.name)

    async def servo(  # type: ignore[override]
        self,
        pin: MegaServoPin,
        *,
        pulse_us: int = 0,
        min_us: int = p.SERVO_DEFAULT_MIN_US,
        max_us: int = p.SERVO_DEFAULT_MAX_US,
    ) -> Servo:
        """Hardware servo PWM on a pin of timers 1, 3, 4 or 5 (see :meth:`Board.servo`)."""
        return await super().servo(
            cast(ServoPin, pin), pulse_us=pulse_us, min_us=min_us, max_us=max_us
        )

    async def soft_pwm(  # type: ignore[override]
        self,
        pin: MegaSoftPwmPin,
        *,
        pulse_us: int = 0,
        min_us: int = p.SERVO_DEFAULT_MIN_US,
        max_us: int = p.SERVO_DEFAULT_MAX_US,
    ) -> SoftPwm:
        """Software servo PWM on D22-D29 (see :meth:`Board.soft_pwm`)."""
        return await super().soft_pwm(
            cast(SoftPwmPin, pin), pulse_us=pulse_us, min_us=min_us, max_us=max_us
        )

    async def pwm(  # type: ignore[override]
        self, pin: MegaDutyPwmPin, duty: float = 0.0, *, frequency_hz: int | None = None
    ) -> DutyPwm:
        """Duty-cycle PWM on a pin of timers 1, 3, 4 or 5 (see :meth:`Board.pwm`)."""
        return await super().pwm(cast(DutyPwmPin, pin), duty, frequency_hz=frequency_hz)

    async def counter(self, pin: MegaCounterPin, *, edge: p.Edge = p.Edge.RISING) -> Counter:
        """An event counter on an external-interrupt pin: D2, D3, D18-D21."""
        return await super().counter(cast(CounterPin, pin), edge=edge)

    async def spi(
        self,
        cs: MegaSpiCsPin,
        *,
        mode: int = 0,
        clock_hz: int = 1_000_000,
        bit_order: BitOrderName = "msb",
    ) -> SpiBus:
        """The SPI master on D50-D52 with chip select ``cs`` (see :meth:`Board.spi`)."""
        return await super().spi(
            cast(SpiCsPin, cs), mode=mode, clock_hz=clock_hz, bit_order=bit_order
        )
