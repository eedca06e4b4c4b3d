"""I2C commands (class tag 0x04), handled by ``firmware/src/i2c.c``.

The master on A4/A5.  A read's reply carries the data and a write's reply its length in
place of the other's: the reply echoes the device and register, and ``matches`` checks
the length too.

I2C BLOCK (extension, ``firmware/src/i2cblock.c``) names a register block the board
reads by itself every stream period when the stream carries ``StreamFlags.I2C``: the
read is interrupt-driven, started at the sampling instant and overlapping the ADC chain,
so a 14-byte read at 400 kHz (~400 us) never blocks the main loop or the UART.  A failed
read (NACK, timeout, lost arbitration) marks that sample's block invalid with the error
code and counts it in I2C BLOCK STATUS's ``errors``; the stream goes on.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import MAX_BLOB, ClassTag, I2CSpeed
from .._layout import U8, U16, Blob
from .._messages import Reply, Request, echo, reply_frame, request_frame

__all__ = [
    "I2CBlock",
    "I2CBlockReply",
    "I2CBlockStatus",
    "I2CBlockStatusReply",
    "I2CConfig",
    "I2CConfigReply",
    "I2CRead",
    "I2CReadReply",
    "I2CWrite",
    "I2CWriteReply",
]


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


@echo
class _BlockSlot:
    slot: Annotated[int, U8]


@echo
class _Block(_BlockSlot):
    address: Annotated[int, U8]
    register: Annotated[int, U8]
    #: Bytes to read each period; 0 frees the slot.
    length: Annotated[int, U8]


@reply_frame(ClassTag.I2C, 0x04)
class I2CBlockReply(_Block, Reply): ...


@request_frame(I2CBlockReply, extension=True, idempotent=True)
class I2CBlock(_Block, Request[I2CBlockReply]):
    """Read ``length`` bytes from ``register`` of ``address`` every stream period in
    ``slot`` (0 frees it); its error count starts at 0.  Refused while the stream runs."""


@reply_frame(ClassTag.I2C, 0x05)
class I2CBlockStatusReply(_BlockSlot, Reply):
    #: Failed reads since I2C BLOCK configured the slot (16 bit, wrapping).
    errors: Annotated[int, U16]
    #: The error code of the last failed read (0: none yet).
    last_error: Annotated[int, U8]


@request_frame(I2CBlockStatusReply, extension=True, reads_only=True)
class I2CBlockStatus(_BlockSlot, Request[I2CBlockStatusReply]):
    """A block's bus errors since it was configured."""
