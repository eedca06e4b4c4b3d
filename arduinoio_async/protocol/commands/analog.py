"""ANALOG commands (class tag 0x03), handled by ``firmware/src/analog.c``.

Single conversions of A0-A5 against AVCC; the replies check the 10-bit range, which
catches corrupt frames the 8-bit checksum lets through.  ANALOG WATCH and the
AnalogChange events it starts are a protocol extension (docs/protocol.md 7.4).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U8, U16, U32, Array
from .._messages import (
    Event,
    Reply,
    Request,
    check_10_bit,
    echo,
    event_frame,
    reply_frame,
    request_frame,
)

__all__ = [
    "AnalogChange",
    "AnalogRead",
    "AnalogReadAll",
    "AnalogReadAllReply",
    "AnalogReadReply",
    "AnalogWatch",
    "AnalogWatchReply",
]


@echo
class _Channel:
    channel: Annotated[int, U8]


@reply_frame(ClassTag.ANALOG, 0x02)
class AnalogReadReply(_Channel, Reply):
    value: Annotated[int, U16]

    def __post_init__(self) -> None:
        check_10_bit(self.value)


@request_frame(AnalogReadReply, reads_only=True)
class AnalogRead(_Channel, Request[AnalogReadReply]):
    """One 10-bit conversion of channel 0-5 against AVCC."""


@reply_frame(ClassTag.ANALOG, 0x03)
class AnalogReadAllReply(Reply):
    values: Annotated[tuple[int, ...], Array(U16, 6)]

    def __post_init__(self) -> None:
        for value in self.values:
            check_10_bit(value)


@request_frame(AnalogReadAllReply, reads_only=True)
class AnalogReadAll(Request[AnalogReadAllReply]):
    """All six channels, A0 first."""


@echo
class _Watch(_Channel):
    deadband: Annotated[int, U16]


@reply_frame(ClassTag.ANALOG, 0x04)
class AnalogWatchReply(_Watch, Reply):
    """``value`` is a conversion made as the request took effect: the baseline the next
    AnalogChange is measured from."""

    value: Annotated[int, U16]

    def __post_init__(self) -> None:
        check_10_bit(self.value)


@request_frame(AnalogWatchReply, extension=True, idempotent=True)
class AnalogWatch(_Watch, Request[AnalogWatchReply]):
    """Report channel 0-5 when it moves by more than ``deadband`` counts (1-1023) from
    the value last reported, as an AnalogChange event; ``deadband`` 0 stops.

    The board samples the watched channels in turn from its 100 us timer tick; refused
    with PIN_BUSY while a stream converts analog channels (and a stream with analog
    channels is refused while a channel is watched), or for A4/A5 while I2C is on.
    """


@event_frame(0x05)
class AnalogChange(Event):
    """A watched channel moved past its deadband (docs/protocol.md 7.4).

    ``value`` becomes the new reference; ``sequence`` counts every analog change event
    the board produced for all channels together, sent or not (a full transmit buffer
    drops one), so the host sees a loss as a gap; ``timestamp_us`` is the board's clock
    when the conversion ended.
    """

    channel: Annotated[int, U8]
    value: Annotated[int, U16]
    sequence: Annotated[int, U16]
    timestamp_us: Annotated[int, U32]

    def __post_init__(self) -> None:
        check_10_bit(self.value)
