"""ANALOG commands (class tag 0x03), handled by ``firmware/src/analog.c``.

Single conversions of A0-A5 against AVCC; the replies check the 10-bit range, which
catches corrupt frames the 8-bit checksum lets through.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U8, U16, Array
from .._messages import Reply, Request, check_10_bit, echo, reply_frame, request_frame

__all__ = ["AnalogRead", "AnalogReadAll", "AnalogReadAllReply", "AnalogReadReply"]


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
