"""The Uno's pins and what each can do: the paper's Table III.

Pins are enum members so that ``Literal`` types can name the pins a function accepts
(``ServoPin = Literal[DigitalPin.D9, DigitalPin.D10]``): mypy then rejects
``board.servo(D2)`` before the program runs, and :func:`require` rejects it at run time
with a message that names the pins that can do it.  D0 and D1 carry the serial link and
are not available.
"""

from __future__ import annotations

from enum import Enum, IntEnum
from typing import Final, Literal

from ..errors import PinCapabilityError

__all__ = [
    "A0",
    "A1",
    "A2",
    "A3",
    "A4",
    "A5",
    "D2",
    "D3",
    "D4",
    "D5",
    "D6",
    "D7",
    "D8",
    "D9",
    "D10",
    "D11",
    "D12",
    "D13",
    "TABLE_III",
    "AnalogPin",
    "CounterPin",
    "DigitalPin",
    "DutyPwmPin",
    "Function",
    "Pin",
    "PwmPin",
    "ServoPin",
    "SoftPwmPin",
    "SpiCsPin",
    "capable_pins",
    "pin_mask",
    "require",
]


class DigitalPin(IntEnum):
    """Digital header pins; the value is the Arduino pin number sent on the wire."""

    D2 = 2
    D3 = 3
    D4 = 4
    D5 = 5
    D6 = 6
    D7 = 7
    D8 = 8
    D9 = 9
    D10 = 10
    D11 = 11
    D12 = 12
    D13 = 13

    def __str__(self) -> str:
        return self.name


class AnalogPin(IntEnum):
    """Analog header pins; the value is the ADC channel sent on the wire."""

    A0 = 0
    A1 = 1
    A2 = 2
    A3 = 3
    A4 = 4
    A5 = 5

    def __str__(self) -> str:
        return self.name


Pin = DigitalPin | AnalogPin

D2: Final = DigitalPin.D2
D3: Final = DigitalPin.D3
D4: Final = DigitalPin.D4
D5: Final = DigitalPin.D5
D6: Final = DigitalPin.D6
D7: Final = DigitalPin.D7
D8: Final = DigitalPin.D8
D9: Final = DigitalPin.D9
D10: Final = DigitalPin.D10
D11: Final = DigitalPin.D11
D12: Final = DigitalPin.D12
D13: Final = DigitalPin.D13
A0: Final = AnalogPin.A0
A1: Final = AnalogPin.A1
A2: Final = AnalogPin.A2
A3: Final = AnalogPin.A3
A4: Final = AnalogPin.A4
A5: Final = AnalogPin.A5

ServoPin = Literal[DigitalPin.D9, DigitalPin.D10]
SoftPwmPin = Literal[
    DigitalPin.D2, DigitalPin.D3, DigitalPin.D4, DigitalPin.D5, DigitalPin.D6, DigitalPin.D7
]
PwmPin = ServoPin | SoftPwmPin
CounterPin = Literal[DigitalPin.D2, DigitalPin.D3]
#: Pins with a hardware timer's output compare unit free for duty-cycle PWM (D11's OC2A
#: is not: its compare register sets the board tick's period; docs/motors.md).
DutyPwmPin = Literal[DigitalPin.D3, DigitalPin.D5, DigitalPin.D6, DigitalPin.D9, DigitalPin.D10]
#: Pins that can be an SPI chip select: every digital pin but D11-D13 (MOSI, MISO, SCK).
SpiCsPin = Literal[
    DigitalPin.D2,
    DigitalPin.D3,
    DigitalPin.D4,
    DigitalPin.D5,
    DigitalPin.D6,
    DigitalPin.D7,
    DigitalPin.D8,
    DigitalPin.D9,
    DigitalPin.D10,
]


class Function(Enum):
    """The I/O functions of Table III; the value reads well in error messages."""

    DIGITAL_INPUT = "digital input"
    DIGITAL_OUTPUT = "digital output"
    ANALOG_INPUT = "analog input"
    SOFT_PWM = "software PWM"
    SERVO_PWM = "servo PWM"
    I2C = "I2C"
    COUNTER = "event counter"
    DUTY_PWM = "duty-cycle PWM"
    ENCODER = "quadrature encoder"
    SPI = "SPI"
    SPI_CS = "SPI chip select"
    PULSE_IN = "pulse-width input"
    SONAR = "sonar"


_DIGITAL = tuple(DigitalPin)

#: Table III of the paper: which pins can do what.
TABLE_III: Final[dict[Function, tuple[Pin, ...]]] = {
    Function.DIGITAL_INPUT: _DIGITAL,
    Function.DIGITAL_OUTPUT: _DIGITAL,
    Function.ANALOG_INPUT: tuple(AnalogPin),
    Function.SOFT_PWM: (D2, D3, D4, D5, D6, D7),
    Function.SERVO_PWM: (D9, D10),
    Function.I2C: (A4, A5),
    Function.COUNTER: (D2, D3),
    Function.DUTY_PWM: (D3, D5, D6, D9, D10),
    #: Pin-change interrupts on every digital pin (INT0/INT1 on D2/D3).
    Function.ENCODER: _DIGITAL,
    #: The AVR's SPI unit: MOSI, MISO, SCK (extension).
    Function.SPI: (D11, D12, D13),
    #: Any digital pin the SPI unit does not use (extension).
    Function.SPI_CS: (D2, D3, D4, D5, D6, D7, D8, D9, D10),
    #: Pin-change interrupts on every digital pin.
    Function.PULSE_IN: _DIGITAL,
    #: Trigger (an output) and echo (pin-change interrupts) on any digital pin.
    Function.SONAR: _DIGITAL,
}


def capable_pins(function: Function) -> tuple[Pin, ...]:
    """The pins that can do ``function``."""
    return TABLE_III[function]


def require(pin: object, function: Function) -> None:
    """Raise :class:`PinCapabilityError` unless ``pin`` can do ``function``."""
    pins = TABLE_III[function]
    if not any(pin is p for p in pins):
        named = isinstance(pin, DigitalPin | AnalogPin)
        name = pin.name if isinstance(pin, DigitalPin | AnalogPin) else repr(pin)
        number = not named and isinstance(pin, int) and not isinstance(pin, bool)
        raise PinCapabilityError(name, function.value, [p.name for p in pins], number=number)


def pin_mask(function: Function) -> int:
    """Bit n set when pin/channel n can do ``function`` (for the firmware header)."""
    mask = 0
    for pin in TABLE_III[function]:
        mask |= 1 << int(pin)
    return mask
