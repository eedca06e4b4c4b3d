"""Board models: which pins of each supported board can do what (issue 29).

A board describes itself (READ_BOARD_DESCRIPTION, extension): its model and, per
:class:`~arduinoio_async.protocol.pins.Function`, the pins that can do it.  This module is
the one place the library, FakeBoard, the docs and the firmware's tables (rendered into
``aio_protocol.h`` by ``cheader``) take that data from: the Uno R3's is the paper's Table
III (``pins.TABLE_III``), the Mega 2560's is below (ATmega2560 datasheet, issue 29).

Pins are Arduino pin numbers: D\\ *n* is *n*, analog input A\\ *n* is
``digital_pins + n`` (A0 is 14 on the Uno, 54 on the Mega), the numbering the Arduino
core uses; D0/D1 carry the host link and can do nothing.  On the wire each function is a
bitmap of ``ceil(pins / 8)`` bytes, pin 0 in bit 0 of the first byte (docs/protocol.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Final

from ..errors import PinCapabilityError, ProtocolError
from ._constants import BOARD_PAGE_BYTES, BoardModelId
from .commands.misc import ReadBoardDescriptionReply
from .pins import TABLE_III, AnalogPin, DigitalPin, Function

__all__ = [
    "BOARD_MODELS",
    "MEGA2560",
    "UNO_R3",
    "WIRE_FUNCTIONS",
    "BoardModel",
    "model_from_pages",
]

#: The functions in wire order: a description's maps come in this order (a new function
#: is added at the end, so an older host reads the maps it knows and skips the rest).
WIRE_FUNCTIONS: Final = tuple(Function)


@dataclass(frozen=True, eq=False)
class BoardModel:
    """One board model: its name, MCU, USB bridge and the pins per function."""

    #: Short name used by the CLI and ``Board.open(model=...)``: ``uno_r3``, ``mega2560``.
    key: str
    model_id: int
    name: str
    mcu: str
    #: The USB-serial bridge of the genuine board (clones differ: docs/boards.md).
    bridge: str
    digital_pins: int
    analog_pins: int
    #: Arduino pin numbers per function (a function the board cannot do maps to ()).
    functions: Mapping[Function, tuple[int, ...]]

    @property
    def pin_count(self) -> int:
        return self.digital_pins + self.analog_pins

    @property
    def map_bytes(self) -> int:
        """Bytes of one function's pin bitmap on the wire."""
        return (self.pin_count + 7) // 8

    def pin_name(self, number: int) -> str:
        """``D13`` or ``A0`` for an Arduino pin number."""
        if number < self.digital_pins:
            return f"D{number}"
        return f"A{number - self.digital_pins}"

    def pin_numbers(self, function: Function) -> tuple[int, ...]:
        return self.functions.get(function, ())

    def pin_names(self, function: Function) -> tuple[str, ...]:
        return tuple(self.pin_name(n) for n in self.pin_numbers(function))

    def pin_ranges(self, function: Function) -> str:
        """``D2-D13, A0-A5``: the function's pins, runs of neighbours as ranges ("none")."""
        runs: list[list[int]] = []
        for number in self.pin_numbers(function):
            same_kind = runs and (runs[-1][-1] < self.digital_pins) == (number < self.digital_pins)
            if runs and same_kind and number == runs[-1][-1] + 1:
                runs[-1].append(number)
            else:
                runs.append([number])
        parts = [
            self.pin_name(run[0])
            if len(run) == 1
            else f"{self.pin_name(run[0])}{'-' if len(run) > 2 else ', '}{self.pin_name(run[-1])}"
            for run in runs
        ]
        return ", ".join(parts) or "none"

    def number_of(self, pin: object) -> int | None:
        """The Arduino pin number of a pin object, None for anything that is not a pin."""
        if isinstance(pin, AnalogPin):
            return self.digital_pins + int(pin) if int(pin) < self.analog_pins else None
        if isinstance(pin, DigitalPin):
            return int(pin) if int(pin) < self.digital_pins else None
        return None

    def can(self, pin: object, function: Function) -> bool:
        number = self.number_of(pin)
        return number is not None and number in self.pin_numbers(function)

    def require(self, pin: object, function: Function) -> None:
        """Raise :class:`PinCapabilityError` unless ``pin`` can do ``function`` here.

        The same error, with the same words, as :func:`pins.require` gives for the Uno,
        naming the pins of this board that can do it.
        """
        if self.can(pin, function):
            return
        named = isinstance(pin, DigitalPin | AnalogPin)
        name = pin.name if isinstance(pin, DigitalPin | AnalogPin) else repr(pin)
        number = not named and isinstance(pin, int) and not isinstance(pin, bool)
        raise PinCapabilityError(
            name, function.value, list(self.pin_names(function)), number=number
        )

    # ---- the wire form -----------------------------------------------------------------------

    def pin_map(self, function: Function) -> bytes:
        """The function's bitmap: pin n in bit n % 8 of byte n // 8."""
        mask = 0
        for number in self.pin_numbers(function):
            mask |= 1 << number
        return mask.to_bytes(self.map_bytes, "little")

    def table(self) -> bytes:
        """The firmware's flash table: model, digital pins, analog pins, function count,
        then every function's map in wire order (rendered into aio_protocol.h)."""
        head = bytes((self.model_id, self.digital_pins, self.analog_pins, len(WIRE_FUNCTIONS)))
        return head + b"".join(self.pin_map(f) for f in WIRE_FUNCTIONS)

    @property
    def maps_per_page(self) -> int:
        return BOARD_PAGE_BYTES // self.map_bytes

    @property
    def pages(self) -> int:
        return -(-len(WIRE_FUNCTIONS) // self.maps_per_page)

    def page(self, index: int) -> bytes:
        """The map bytes of description page ``index`` (what the board sends)."""
        first = index * self.maps_per_page
        functions = WIRE_FUNCTIONS[first : first + self.maps_per_page]
        return b"".join(self.pin_map(f) for f in functions)

    def reply(self, index: int) -> ReadBoardDescriptionReply | None:
        """Description page ``index`` as the board answers it; None past the last page."""
        if not 0 <= index < self.pages:
            return None
        head = (self.model_id, self.digital_pins, self.analog_pins, len(WIRE_FUNCTIONS))
        return ReadBoardDescriptionReply(index, *head, self.page(index))


def _numbers(pins: Iterable[DigitalPin | AnalogPin], digital_pins: int) -> tuple[int, ...]:
    return tuple(sorted(int(p) + (digital_pins if isinstance(p, AnalogPin) else 0) for p in pins))


#: The Arduino Uno R3 (and every ATmega328P board running the Uno image: Nano clones
#: report this model too): the paper's Table III.
UNO_R3: Final = BoardModel(
    key="uno_r3",
    model_id=BoardModelId.UNO_R3,
    name="Arduino Uno R3",
    mcu="ATmega328P",
    bridge="ATmega16U2",
    digital_pins=14,
    analog_pins=6,
    functions={f: _numbers(TABLE_III[f], 14) for f in Function},
)

_MEGA_DIGITAL = tuple(range(2, 54))
_MEGA_A0 = 54
#: INT0-INT5: D21, D20, D19, D18, D2, D3.
_MEGA_INT = (2, 3, 18, 19, 20, 21)
#: PCINT0-7 (PB0-7: D53, D52, D51, D50, D10-D13), PCINT9/10 (PJ0/1: D15, D14),
#: PCINT16-23 (PK0-7: A8-A15).
_MEGA_PCINT = (10, 11, 12, 13, 14, 15, 50, 51, 52, 53, *range(_MEGA_A0 + 8, _MEGA_A0 + 16))
#: Output compare pins of timers 1, 3, 4 and 5 (OC1A/B D11/D12, OC3A-C D5/D2/D3,
#: OC4A-C D6-D8, OC5A-C D46/D45/D44); timers 0 and 2 keep the board's tick and soft PWM.
_MEGA_TIMER_PINS = (2, 3, 5, 6, 7, 8, 11, 12, 44, 45, 46)
_MEGA_SPI = (50, 51, 52)

#: The Arduino Mega 2560 (R3): the ATmega2560's pins as issue 29 lists them.  The Mega
#: firmware (board_mega2560.c) reports this table; the w4-mega work may refine it.
MEGA2560: Final = BoardModel(
    key="mega2560",
    model_id=BoardModelId.MEGA2560,
    name="Arduino Mega 2560",
    mcu="ATmega2560",
    bridge="ATmega16U2",
    digital_pins=54,
    analog_pins=16,
    functions={
        Function.DIGITAL_INPUT: _MEGA_DIGITAL,
        Function.DIGITAL_OUTPUT: _MEGA_DIGITAL,
        Function.ANALOG_INPUT: tuple(range(_MEGA_A0, _MEGA_A0 + 16)),
        #: Port A (D22-D29): one port, one write per soft PWM edge, as PORTD on the Uno.
        Function.SOFT_PWM: tuple(range(22, 30)),
        Function.SERVO_PWM: _MEGA_TIMER_PINS,
        Function.I2C: (20, 21),
        Function.COUNTER: _MEGA_INT,
        Function.DUTY_PWM: _MEGA_TIMER_PINS,
        Function.ENCODER: tuple(sorted({*_MEGA_INT, *_MEGA_PCINT})),
        Function.SPI: _MEGA_SPI,
        Function.SPI_CS: tuple(n for n in _MEGA_DIGITAL if n not in _MEGA_SPI),
        Function.PULSE_IN: tuple(sorted({*_MEGA_INT, *_MEGA_PCINT})),
        #: The echo is timed from pin-change stamps, as a pulse input's is.
        Function.SONAR: tuple(sorted({*_MEGA_INT, *_MEGA_PCINT})),
    },
)

#: Every model the library knows, by wire ID.
BOARD_MODELS: Final[Mapping[int, BoardModel]] = {m.model_id: m for m in (UNO_R3, MEGA2560)}


def model_from_pages(
    model_id: int, digital_pins: int, analog_pins: int, maps: Sequence[bytes]
) -> BoardModel:
    """The model a board described: the known model's name and MCU, the board's pins.

    ``maps`` are the function maps in wire order, as many as the board sent (a function
    this library does not know is skipped, one it knows and the board did not send maps
    to no pins).  The reported pins win over the known model's: they are the image's.
    """
    width = (digital_pins + analog_pins + 7) // 8
    functions: dict[Function, tuple[int, ...]] = {}
    for function, raw in zip(WIRE_FUNCTIONS, maps, strict=False):
        if len(raw) != width:
            raise ProtocolError(f"board description: a {len(raw)}-byte map, expected {width}")
        mask = int.from_bytes(raw, "little")
        functions[function] = tuple(n for n in range(digital_pins + analog_pins) if mask >> n & 1)
    known = BOARD_MODELS.get(model_id)
    return BoardModel(
        key=known.key if known else f"model_{model_id:02x}",
        model_id=model_id,
        name=known.name if known else f"unknown board model 0x{model_id:02X}",
        mcu=known.mcu if known else "unknown",
        bridge=known.bridge if known else "unknown",
        digital_pins=digital_pins,
        analog_pins=analog_pins,
        functions=functions,
    )
