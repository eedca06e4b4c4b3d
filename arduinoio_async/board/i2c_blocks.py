"""I2C register blocks the board reads by itself every stream period (extension).

``board.stream(i2c=[I2CBlock(0x68, 0x3B, 14)], ...)`` names up to ``I2C_BLOCK_SLOTS``
blocks (``I2C_BLOCK_BYTES`` bytes together: the board reads them into the sample frame, so
the limit is its frame buffer, not a separate copy); the bus must be set up first
(``await board.i2c(...)``).  The board starts the read at each sampling instant and runs it
from the TWI interrupt, so a 14-byte read at 400 kHz (~400 us) overlaps the analog
conversions and never blocks the main loop or the UART.  Each sample carries the blocks'
bytes in :attr:`Sample.i2c <arduinoio_async.board.streaming.Sample.i2c>` (``None`` for a
read that failed that period: NACK, timeout, lost arbitration) and the board counts the
failures (:func:`block_errors`).  While such a stream runs the bus is the stream's: a
one-shot read or write is refused (``I2C_STREAMING``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .. import protocol as p
from ..errors import UsageError, ValueRangeError

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["I2CBlock", "block_errors", "block_requests", "blocks_bytes"]


@dataclass(frozen=True, slots=True)
class I2CBlock:
    """``length`` bytes from ``register`` of the device at ``address`` (7-bit), read every
    stream period (``I2CBlock(0x68, 0x3B, 14)``: an MPU-6050's accelerometer, temperature
    and gyroscope)."""

    address: int
    register: int
    length: int

    def __post_init__(self) -> None:
        if not isinstance(self.address, int) or not 0 <= self.address <= 0x7F:
            raise ValueRangeError("I2C address", self.address, "7-bit, 0x00-0x7F")
        if not isinstance(self.register, int) or not 0 <= self.register <= 0xFF:
            raise ValueRangeError("I2C register", self.register, "0x00-0xFF")
        if not isinstance(self.length, int) or not 1 <= self.length <= p.I2C_BLOCK_BYTES:
            raise ValueRangeError("I2C block length", self.length, f"1-{p.I2C_BLOCK_BYTES}")


def blocks_bytes(blocks: Sequence[I2CBlock]) -> int:
    """The data bytes the blocks add to a sample (their headers aside)."""
    return sum(block.length for block in blocks)


def block_requests(blocks: Sequence[I2CBlock]) -> list[p.I2CBlock]:
    """The I2C BLOCK requests that set the board's slots to ``blocks`` (slot k = the k-th
    block; the slots after them freed), after checking the board's limits."""
    blocks = list(blocks)
    if not all(isinstance(block, I2CBlock) for block in blocks):
        raise UsageError("i2c= takes I2CBlock(address, register, length) values")
    if not 1 <= len(blocks) <= p.I2C_BLOCK_SLOTS:
        raise ValueRangeError("I2C blocks", len(blocks), f"1-{p.I2C_BLOCK_SLOTS} a stream")
    if blocks_bytes(blocks) > p.I2C_BLOCK_BYTES:
        raise ValueRangeError(
            "I2C block bytes", blocks_bytes(blocks), f"at most {p.I2C_BLOCK_BYTES} together"
        )
    requests = [p.I2CBlock(k, b.address, b.register, b.length) for k, b in enumerate(blocks)]
    requests += [p.I2CBlock(k, 0, 0, 0) for k in range(len(blocks), p.I2C_BLOCK_SLOTS)]
    return requests


async def block_errors(board: BoardCore, index: int) -> int:
    """Failed reads of the ``index``-th block of the stream since it was set up (16-bit,
    wrapping): the board's count, which also covers samples that never reached the host."""
    if not 0 <= index < p.I2C_BLOCK_SLOTS:
        raise ValueRangeError("I2C block index", index, f"0-{p.I2C_BLOCK_SLOTS - 1}")
    return (await board.request(p.I2CBlockStatus(index))).errors
