"""I2C commands (class tag 0x04), handled by ``firmware/src/i2c.c``.

The master on A4/A5.  A read's reply carries the data and a write's reply its length in
place of the other's: the reply echoes the device and register, and ``matches`` checks
the length too.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import MAX_BLOB, ClassTag, I2CSpeed
from .._layout import U8, Blob
from .._messages import Reply, Request, echo, reply_frame, request_frame

__all__ = ["I2CConfig", "I2CConfigReply", "I2CRead", "I2CReadReply", "I2CWrite", "I2CWriteReply"]


@echo
class _Speed:
    speed: Annotated[I2CSpeed, U8]


@reply_frame(ClassTag.I2C, 0x01)
class I2CConfigReply(_Speed, Reply): ...


@request_frame(I2CConfigReply, idempotent=True)
class I2CConfig(_Speed, Request[I2CConfigReply]):
    """Enable the I2C master on A4/A5 at 100 or 400 kHz."""


@echo
class _Register:
    address: Annotated[int, U8]
    register: Annotated[int, U8]


@reply_frame(ClassTag.I2C, 0x02)
class I2CReadReply(_Register, Reply):
    data: Annotated[bytes, Blob(MAX_BLOB)]


@request_frame(I2CReadReply, reads_only=True)
class I2CRead(_Register, Request[I2CReadReply]):
    """Write the register offset, repeated start, read ``length`` bytes (7-bit address)."""

    length: Annotated[int, U8]

    def matches(self, reply: Reply) -> bool:
        return (
            Request.matches(self, reply)
            and isinstance(reply, I2CReadReply)
            and len(reply.data) == self.length
        )


@reply_frame(ClassTag.I2C, 0x03)
class I2CWriteReply(_Register, Reply):
    length: Annotated[int, U8]


# Not idempotent: a device may count or queue writes.
@request_frame(I2CWriteReply)
class I2CWrite(_Register, Request[I2CWriteReply]):
    """Write the register offset followed by ``data`` (7-bit address)."""

    data: Annotated[bytes, Blob(MAX_BLOB)]

    def matches(self, reply: Reply) -> bool:
        return (
            Request.matches(self, reply)
            and isinstance(reply, I2CWriteReply)
            and reply.length == len(self.data)
        )
