"""The Mega 2560's pin types: what mypy lets a :class:`~arduinoio_async.board.mega.Mega2560Board`
take, as ``pins.ServoPin`` and the others are the Uno's (issue 29).

The pins per function are data in :data:`~arduinoio_async.protocol.boards.MEGA2560`; a
``Literal`` has to be spelled out for mypy, so these repeat it, and
``tests/test_board_model.py`` fails when a type and the data disagree.
"""

from __future__ import annotations

from typing import Literal

from .pins import DigitalPin

__all__ = [
    "MegaCounterPin",
    "MegaDutyPwmPin",
    "MegaServoPin",
    "MegaSoftPwmPin",
    "MegaSpiCsPin",
]

#: Output compare pins of timers 1, 3, 4 and 5.
MegaServoPin = Literal[
    DigitalPin.D2,
    DigitalPin.D3,
    DigitalPin.D5,
    DigitalPin.D6,
    DigitalPin.D7,
    DigitalPin.D8,
    DigitalPin.D11,
    DigitalPin.D12,
    DigitalPin.D44,
    DigitalPin.D45,
    DigitalPin.D46,
]

#: The same timers' pins: duty-cycle PWM.
MegaDutyPwmPin = Literal[
    DigitalPin.D2,
    DigitalPin.D3,
    DigitalPin.D5,
    DigitalPin.D6,
    DigitalPin.D7,
    DigitalPin.D8,
    DigitalPin.D11,
    DigitalPin.D12,
    DigitalPin.D44,
    DigitalPin.D45,
    DigitalPin.D46,
]

#: Port A (D22-D29): software PWM.
MegaSoftPwmPin = Literal[
    DigitalPin.D22,
    DigitalPin.D23,
    DigitalPin.D24,
    DigitalPin.D25,
    DigitalPin.D26,
    DigitalPin.D27,
    DigitalPin.D28,
    DigitalPin.D29,
]

#: External interrupts INT0-INT5.
MegaCounterPin = Literal[
    DigitalPin.D2, DigitalPin.D3, DigitalPin.D18, DigitalPin.D19, DigitalPin.D20, DigitalPin.D21
]

#: Every digital pin but D50-D52 (MISO, MOSI, SCK).
MegaSpiCsPin = Literal[
    DigitalPin.D2,
    DigitalPin.D3,
    DigitalPin.D4,
    DigitalPin.D5,
    DigitalPin.D6,
    DigitalPin.D7,
    DigitalPin.D8,
    DigitalPin.D9,
    DigitalPin.D10,
    DigitalPin.D11,
    DigitalPin.D12,
    DigitalPin.D13,
    DigitalPin.D14,
    DigitalPin.D15,
    DigitalPin.D16,
    DigitalPin.D17,
    DigitalPin.D18,
    DigitalPin.D19,
    DigitalPin.D20,
    DigitalPin.D21,
    DigitalPin.D22,
    DigitalPin.D23,
    DigitalPin.D24,
    DigitalPin.D25,
    DigitalPin.D26,
    DigitalPin.D27,
    DigitalPin.D28,
    DigitalPin.D29,
    DigitalPin.D30,
    DigitalPin.D31,
    DigitalPin.D32,
    DigitalPin.D33,
    DigitalPin.D34,
    DigitalPin.D35,
    DigitalPin.D36,
    DigitalPin.D37,
    DigitalPin.D38,
    DigitalPin.D39,
    DigitalPin.D40,
    DigitalPin.D41,
    DigitalPin.D42,
    DigitalPin.D43,
    DigitalPin.D44,
    DigitalPin.D45,
    DigitalPin.D46,
    DigitalPin.D47,
    DigitalPin.D48,
    DigitalPin.D49,
    DigitalPin.D53,
]
