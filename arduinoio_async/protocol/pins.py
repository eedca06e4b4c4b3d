"""The pins, and what each of the Uno's can do: the paper's Table III.

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
    "A6",
    "A7",
    "A8",
    "A9",
    "A10",
    "A11",
    "A12",
    "A13",
    "A14",
    "A15",
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
    "D14",
    "D15",
    "D16",
    "D17",
    "D18",
    "D19",
    "D20",
    "D21",
    "D22",
    "D23",
    "D24",
    "D25",
    "D26",
    "D27",
    "D28",
    "D29",
    "D30",
    "D31",
    "D32",
    "D33",
    "D34",
    "D35",
    "D36",
    "D37",
    "D38",
    "D39",
    "D40",
    "D41",
    "D42",
    "D43",
    "D44",
    "D45",
    "D46",
    "D47",
    "D48",
    "D49",
    "D50",
    "D51",
    "D52",
    "D53",
    "TABLE_III",
    "UNO_ANALOG",
    "UNO_DIGITAL",
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
    """Digital header pins; the value is the Arduino pin number sent on the wire.

    D2-D13 are the Uno's, D14-D53 the Mega 2560's (protocol/boards.py): which a board has
    is its model's business, checked before anything is sent; the Uno's handle methods
    take the Literal types below, so mypy refuses a Mega pin there.
    """

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
    D14 = 14
    D15 = 15
    D16 = 16
    D17 = 17
    D18 = 18
    D19 = 19
    D20 = 20
    D21 = 21
    D22 = 22
    D23 = 23
    D24 = 24
    D25 = 25
    D26 = 26
    D27 = 27
    D28 = 28
    D29 = 29
    D30 = 30
    D31 = 31
    D32 = 32
    D33 = 33
    D34 = 34
    D35 = 35
    D36 = 36
    D37 = 37
    D38 = 38
    D39 = 39
    D40 = 40
    D41 = 41
    D42 = 42
    D43 = 43
    D44 = 44
    D45 = 45
    D46 = 46
    D47 = 47
    D48 = 48
    D49 = 49
    D50 = 50
    D51 = 51
    D52 = 52
    D53 = 53

    def __str__(self) -> str:
        return self.name


class AnalogPin(IntEnum):
    """Analog header pins; the value is the ADC channel sent on the wire (A0-A5 on the
    Uno, A0-A15 on the Mega 2560)."""

    A0 = 0
    A1 = 1
    A2 = 2
    A3 = 3
    A4 = 4
    A5 = 5
    A6 = 6
    A7 = 7
    A8 = 8
    A9 = 9
    A10 = 10
    A11 = 11
    A12 = 12
    A13 = 13
    A14 = 14
    A15 = 15

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
D14: Final = DigitalPin.D14
D15: Final = DigitalPin.D15
D16: Final = DigitalPin.D16
D17: Final = DigitalPin.D17
D18: Final = DigitalPin.D18
D19: Final = DigitalPin.D19
D20: Final = DigitalPin.D20
D21: Final = DigitalPin.D21
D22: Final = DigitalPin.D22
D23: Final = DigitalPin.D23
D24: Final = DigitalPin.D24
D25: Final = DigitalPin.D25
D26: Final = DigitalPin.D26
D27: Final = DigitalPin.D27
D28: Final = DigitalPin.D28
D29: Final = DigitalPin.D29
D30: Final = DigitalPin.D30
D31: Final = DigitalPin.D31
D32: Final = DigitalPin.D32
D33: Final = DigitalPin.D33
D34: Final = DigitalPin.D34
D35: Final = DigitalPin.D35
D36: Final = DigitalPin.D36
D37: Final = DigitalPin.D37
D38: Final = DigitalPin.D38
D39: Final = DigitalPin.D39
D40: Final = DigitalPin.D40
D41: Final = DigitalPin.D41
D42: Final = DigitalPin.D42
D43: Final = DigitalPin.D43
D44: Final = DigitalPin.D44
D45: Final = DigitalPin.D45
D46: Final = DigitalPin.D46
D47: Final = DigitalPin.D47
D48: Final = DigitalPin.D48
D49: Final = DigitalPin.D49
D50: Final = DigitalPin.D50
D51: Final = DigitalPin.D51
D52: Final = DigitalPin.D52
D53: Final = DigitalPin.D53
A0: Final = AnalogPin.A0
A1: Final = AnalogPin.A1
A2: Final = AnalogPin.A2
A3: Final = AnalogPin.A3
A4: Final = AnalogPin.A4
A5: Final = AnalogPin.A5
A6: Final = AnalogPin.A6
A7: Final = AnalogPin.A7
A8: Final = AnalogPin.A8
A9: Final = AnalogPin.A9
A10: Final = AnalogPin.A10
A11: Final = AnalogPin.A11
A12: Final = AnalogPin.A12
A13: Final = AnalogPin.A13
A14: Final = AnalogPin.A14
A15: Final = AnalogPin.A15

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


#: The Uno's header: D2-D13 (D0/D1 carry the link) and A0-A5.
UNO_DIGITAL: Final = tuple(pin for pin in DigitalPin if pin <= 13)
UNO_ANALOG: Final = tuple(pin for pin in AnalogPin if pin <= 5)
_DIGITAL = UNO_DIGITAL

#: Table III of the paper: which pins can do what.
TABLE_III: Final[dict[Function, tuple[Pin, ...]]] = {
    Function.DIGITAL_INPUT: _DIGITAL,
    Function.DIGITAL_OUTPUT: _DIGITAL,
    Function.ANALOG_INPUT: UNO_ANALOG,
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
