"""The blocking twin of :class:`~arduinoio_async.board.spi.SpiBus`;
``BlockingBoard.spi`` returns it."""

from __future__ import annotations

from ..board.spi import SpiBus
from ._handles import _BlockingPin

__all__ = ["BlockingSpiBus"]


class BlockingSpiBus(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.spi.SpiBus`: full-duplex transfers under the
    chip select (:attr:`pin`); ``release()`` frees all four pins."""

    handle: SpiBus

    def transfer(self, data: bytes) -> bytes:
        """Chip select low, send ``data`` (1-32 bytes), chip select high; what came back."""
        return self._runner.call(self.handle.transfer, data)

    def write(self, data: bytes) -> None:
        """:meth:`transfer` ignoring what comes back."""
        self._runner.call(self.handle.write, data)

    def read(self, length: int, *, fill: int = 0x00) -> bytes:
        """``length`` bytes from the device, sending ``fill`` meanwhile."""
        return self._runner.call(lambda: self.handle.read(length, fill=fill))
