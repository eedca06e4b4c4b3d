"""The FakeBoard's I2C register blocks read every stream period (I2C BLOCK, BLOCK STATUS).

Modelled on ``firmware/src/i2cblock.c``: up to ``I2C_BLOCK_SLOTS`` slots of
``I2C_BLOCK_BYTES`` bytes together; each sample reads every configured slot from the fake
devices (``FakeBoard.i2c_devices``); a device that is not there is a NACK: the slot's
status byte carries I2C_NACK_ADDRESS and the slot's error count goes up.  While a stream
with blocks runs, a one-shot I2C read or write is refused with I2C_STREAMING, and the
blocks cannot change.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .. import protocol as p

if TYPE_CHECKING:
    from ._timed import StreamModel

E = p.ErrorCode

__all__ = ["I2CBlockModels"]


class I2CBlockModels:
    """I2C BLOCK and I2C BLOCK STATUS, the blocks' bytes in a sample (mixed into the
    FakeBoard)."""

    if TYPE_CHECKING:
        stream: StreamModel
        i2c_devices: dict[int, bytearray]
        i2c_speed: p.I2CSpeed | None

        @staticmethod
        def _error(request: p.Frame, code: p.ErrorCode) -> p.ErrorReply: ...

        def _i2c_device(self, request: p.I2CRead | p.I2CWrite) -> bytearray | p.ErrorReply: ...

    @property
    def i2c_blocks(self) -> list[list[int]]:
        """Per slot: [address, register, length, errors, last error] (length 0: free)."""
        if not hasattr(self, "_i2c_blocks"):
            self._i2c_blocks = [[0, 0, 0, 0, 0] for _ in range(p.I2C_BLOCK_SLOTS)]
        return self._i2c_blocks

    def _i2c_block_handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        return {p.I2CBlock: self._i2c_block, p.I2CBlockStatus: self._i2c_block_status}

    def _streams_i2c(self) -> bool:
        request = self.stream.request
        return bool(self.stream.running and request and request.flags & p.StreamFlags.I2C)

    def _i2c_block(self, request: p.I2CBlock) -> p.Frame:
        if request.slot >= p.I2C_BLOCK_SLOTS or request.address > 0x7F:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        others = sum(b[2] for k, b in enumerate(self.i2c_blocks) if k != request.slot)
        if request.length > p.I2C_BLOCK_BYTES or others + request.length > p.I2C_BLOCK_BYTES:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if self._streams_i2c():
            return self._error(request, E.I2C_STREAMING)
        self.i2c_blocks[request.slot] = [request.address, request.register, request.length, 0, 0]
        return p.I2CBlockReply(request.slot, request.address, request.register, request.length)

    def _i2c_block_status(self, request: p.I2CBlockStatus) -> p.Frame:
        if request.slot >= p.I2C_BLOCK_SLOTS:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        block = self.i2c_blocks[request.slot]
        return p.I2CBlockStatusReply(request.slot, block[3] & 0xFFFF, block[4])

    def i2c_block_bytes(self) -> int:
        """The blocks' data bytes together (the sample's I2C part less its headers)."""
        return sum(block[2] for block in self.i2c_blocks)

    def i2c_block_payload(self) -> bytes:
        """The sample's I2C part: per slot length, status and the bytes read now."""
        out = bytearray()
        for block in self.i2c_blocks:
            address, register, length = block[0], block[1], block[2]
            device = self.i2c_devices.get(address) if length else None
            if length and device is None:
                block[3] += 1
                block[4] = E.I2C_NACK_ADDRESS
                out += bytes([length, E.I2C_NACK_ADDRESS]) + bytes(length)
            else:
                data = bytes(device[(register + i) % 256] for i in range(length)) if device else b""
                out += bytes([length, 0]) + data
        return bytes(out)
