"""MISC commands (class tag 0x01), handled by ``firmware/src/misc.c``.

Identity, temperature, capabilities, status and session: what a host asks a board before
and between the commands that drive its pins.  TRANSACTION shares the class tag but has
a module of its own, as in the firmware (``transaction``).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import (
    BOARD_PAGE_BYTES,
    TEMP_MV_AT_25C,
    TEMP_MV_PER_C,
    TEMP_REFERENCE_MV,
    ClassTag,
    Framing,
    StatusFlags,
)
from .._layout import U8, U16, U32, Blob
from .._messages import Reply, Request, check_10_bit, echo, reply_frame, request_frame

__all__ = [
    "ReadBoardDescription",
    "ReadBoardDescriptionReply",
    "ReadCapabilities",
    "ReadCapabilitiesReply",
    "ReadId",
    "ReadIdReply",
    "ReadPinRoles",
    "ReadPinRolesReply",
    "ReadStatus",
    "ReadStatusReply",
    "ReadTemperature",
    "ReadTemperatureReply",
    "Reset",
    "ResetReply",
    "SetFraming",
    "SetFramingReply",
    "SetLowLatency",
    "SetLowLatencyReply",
    "SetSession",
    "SetSessionReply",
    "WriteId",
    "WriteIdReply",
]


@reply_frame(ClassTag.MISC, 0x01)
class ResetReply(Reply):
    """Sent before the watchdog resets the board."""


@request_frame(ResetReply)
class Reset(Request[ResetReply]):
    """Hardware reset: the board answers, then restarts through its watchdog."""


@echo
class _BoardId:
    board_id: Annotated[int, U16]


@reply_frame(ClassTag.MISC, 0x02)
class ReadIdReply(_BoardId, Reply):
    """The paper's Table II: ``01 02 IDH IDL CS``."""


@request_frame(ReadIdReply, reads_only=True)
class ReadId(Request[ReadIdReply]):
    """The paper's Table I: ``01 02 03``."""


@reply_frame(ClassTag.MISC, 0x03)
class ReadTemperatureReply(Reply):
    """Raw 10-bit ADC reading of the chip's sensor against the internal 1.1 V reference."""

    raw: Annotated[int, U16]

    def __post_init__(self) -> None:
        check_10_bit(self.raw)

    @property
    def millivolts(self) -> float:
        return self.raw * TEMP_REFERENCE_MV / 1024

    @property
    def celsius(self) -> float:
        """Datasheet-typical conversion; calibrate per chip for better than +/-10 C."""
        return 25.0 + (self.millivolts - TEMP_MV_AT_25C) / TEMP_MV_PER_C


@request_frame(ReadTemperatureReply, reads_only=True)
class ReadTemperature(Request[ReadTemperatureReply]):
    """Read the chip temperature sensor (ADC channel 8)."""


@reply_frame(ClassTag.MISC, 0x04)
class ReadCapabilitiesReply(Reply):
    """What the firmware is and can do; ``baud`` is the rate it was built for."""

    protocol_version: Annotated[int, U8]
    firmware_major: Annotated[int, U8]
    firmware_minor: Annotated[int, U8]
    features: Annotated[int, U32]
    baud: Annotated[int, U32]
    rx_buffer: Annotated[int, U8]


@request_frame(ReadCapabilitiesReply, extension=True, reads_only=True)
class ReadCapabilities(Request[ReadCapabilitiesReply]):
    """Protocol and firmware version, feature bits, build baud rate, receive FIFO size."""


@reply_frame(ClassTag.MISC, 0x05)
class WriteIdReply(_BoardId, Reply):
    """Sent after the ID has been written to EEPROM and read back."""


# Not idempotent: EEPROM wear, and the board answers with its new ID.
@request_frame(WriteIdReply, extension=True)
class WriteId(_BoardId, Request[WriteIdReply]):
    """Store a new 16-bit board ID in EEPROM."""


@reply_frame(ClassTag.MISC, 0x06)
class ReadStatusReply(Reply):
    """Failsafe and stream state, and the session tag (0 after every boot)."""

    flags: Annotated[StatusFlags, U8]
    session: Annotated[int, U16]


@request_frame(ReadStatusReply, extension=True, reads_only=True)
class ReadStatus(Request[ReadStatusReply]):
    """Cheap heartbeat; a session tag of 0 tells the host the board has rebooted."""


@echo
class _Session:
    session: Annotated[int, U16]


@reply_frame(ClassTag.MISC, 0x07)
class SetSessionReply(_Session, Reply): ...


@request_frame(SetSessionReply, extension=True, idempotent=True)
class SetSession(_Session, Request[SetSessionReply]):
    """Tag this boot of the board so the host can detect a reset by itself later."""


@reply_frame(ClassTag.MISC, 0x08)
class ReadPinRolesReply(Reply):
    """Bit n of each mask is set when Dn has that role on the board (D0/D1 carry the UART).

    Roles last until released or reset, also across host programs, so a bench tool asks
    the board instead of guessing why it refuses a pin.
    """

    gpio_input: Annotated[int, U16]
    gpio_output: Annotated[int, U16]
    pwm: Annotated[int, U16]
    counter: Annotated[int, U16]
    #: RC pulse-width inputs (0 in an image without them).
    pulse_input: Annotated[int, U16]


@request_frame(ReadPinRolesReply, extension=True)
class ReadPinRoles(Request[ReadPinRolesReply]):
    """Which digital pins are GPIO inputs, GPIO outputs, PWM (servo or software), counters
    or pulse-width inputs."""


@echo
class _LowLatency:
    enabled: Annotated[bool, U8]


@reply_frame(ClassTag.MISC, 0x0A)
class SetLowLatencyReply(_LowLatency, Reply): ...


@request_frame(SetLowLatencyReply, extension=True, idempotent=True)
class SetLowLatency(_LowLatency, Request[SetLowLatencyReply]):
    """Pad replies with filler bytes (``FILLER``) so the Uno's 16U2 bridge sends at once.

    After the last reply of a burst the board sends filler until the burst and its filler
    make ``LOW_LATENCY_PAD`` (97) bytes: arduino-usbserial sends what waits when more than
    96 bytes wait, otherwise on its 4.096 ms timer tick.  Costs 97 byte times of the
    board-to-host line per burst, so it pays from 1 Mbaud up (485 us at 2 Mbaud).  Off
    after every boot.
    """


@echo
class _Framing:
    framing: Annotated[Framing, U8]


@reply_frame(ClassTag.MISC, 0x0B)
class SetFramingReply(_Framing, Reply):
    """Sent in the framing just set: a reply that checks in it proves the switch."""


@request_frame(SetFramingReply, extension=True, idempotent=True)
class SetFraming(_Framing, Request[SetFramingReply]):
    """Check every later frame, both ways, by ``framing`` (extension, docs/protocol.md 7.7).

    Sent in the framing in force; the board answers in the new one and parses every
    later request in it.  Back to ``XOR`` after every boot.  The session sends it itself
    (:class:`~arduinoio_async.protocol.session.Session`, ``framing=``), with nothing else
    in flight.
    """


@echo
class _Page:
    page: Annotated[int, U8]


@reply_frame(ClassTag.MISC, 0x0C)
class ReadBoardDescriptionReply(_Page, Reply):
    """One page of the board's description (protocol/boards.py).

    Every page repeats the head (model, digital and analog pin counts, function count) so
    any page read alone names the board; ``maps`` holds as many whole function bitmaps
    (``ceil((digital_pins + analog_pins) / 8)`` bytes each, wire order) as fit in
    BOARD_PAGE_BYTES, from function ``page * (BOARD_PAGE_BYTES // width)`` on.
    """

    model: Annotated[int, U8]
    digital_pins: Annotated[int, U8]
    analog_pins: Annotated[int, U8]
    functions: Annotated[int, U8]
    maps: Annotated[bytes, Blob(BOARD_PAGE_BYTES)]


@request_frame(ReadBoardDescriptionReply, extension=True, reads_only=True)
class ReadBoardDescription(_Page, Request[ReadBoardDescriptionReply]):
    """Page ``page`` of the board's model and pins per function (Feature.BOARD_DESCRIPTION).

    A request of its own rather than a longer capabilities reply: a host that predates it
    decodes the capabilities reply by its fixed length, and the Mega's 70-pin maps (9
    bytes a function) need several frames anyway.  A page past the last one is refused
    with VALUE_OUT_OF_RANGE.
    """
