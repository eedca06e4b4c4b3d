"""SPI commands (class tag 0x0D, extension), handled by ``firmware/src/spi.c``.

The AVR's hardware SPI master on D11 (MOSI), D12 (MISO) and D13 (SCK) with a chip select
on any other digital pin.  CONFIG takes the four pins, the mode (clock polarity and phase),
the clock (a power-of-two divider of the 16 MHz system clock: :class:`SpiClock`) and the
bit order; TRANSFER pulls the chip select low, exchanges its bytes full duplex (the reply
holds exactly as many bytes as were sent, each the byte clocked in while its partner went
out) and lets the chip select go high again, so each transfer is one device transaction.
Releasing any of the four pins (GPIO PIN_RELEASE) ends the bridge and frees them all.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import MAX_BLOB, ClassTag, SpiBitOrder, SpiClock
from .._layout import U8, Blob
from .._messages import Reply, Request, echo, reply_frame, request_frame

__all__ = ["SpiConfig", "SpiConfigReply", "SpiTransfer", "SpiTransferReply"]


@echo
class _Config:
    cs: Annotated[int, U8]
    mode: Annotated[int, U8]
    clock: Annotated[SpiClock, U8]
    order: Annotated[SpiBitOrder, U8]


@reply_frame(ClassTag.SPI, 0x01)
class SpiConfigReply(_Config, Reply): ...


@request_frame(SpiConfigReply, extension=True, idempotent=True)
class SpiConfig(_Config, Request[SpiConfigReply]):
    """Take D11/D12/D13 and ``cs`` for the SPI master in ``mode`` 0-3 at ``clock``.

    The chip select idles high.  A second CONFIG changes the settings (and the chip
    select: the old one is released).
    """


@reply_frame(ClassTag.SPI, 0x02)
class SpiTransferReply(Reply):
    #: The bytes clocked in on MISO, one per byte sent.
    received: Annotated[bytes, Blob(MAX_BLOB)]


# Not idempotent: a device may act on what it is sent (a write, a FIFO read).
@request_frame(SpiTransferReply, extension=True)
class SpiTransfer(Request[SpiTransferReply]):
    """Chip select low, exchange ``data`` (1-32 bytes) full duplex, chip select high."""

    data: Annotated[bytes, Blob(MAX_BLOB)]

    def matches(self, reply: Reply) -> bool:
        return (
            Request.matches(self, reply)
            and isinstance(reply, SpiTransferReply)
            and len(reply.received) == len(self.data)
        )
