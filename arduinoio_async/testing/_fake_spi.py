"""The FakeBoard's SPI bridge: ``firmware/src/spi.c`` as a model, with a device on the bus.

Mixed into :class:`~arduinoio_async.testing.FakeBoard` over the digital pins' model: SPI
CONFIG takes D11-D13 and the chip select (role ``"spi"``), a release of any of them ends
the bridge and frees all four.  What answers a transfer is :attr:`SpiModels.spi_device`,
a function from the bytes sent to the bytes received: by default MISO wired to MOSI (the
firmware host tests' loopback); :class:`FakeMcp3008` models the MCP3008 of the docs.
Every transfer is recorded in :attr:`SpiModels.spi_frames` (the bytes sent and received).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from .. import protocol as p
from ..protocol.pins import Function
from ._gpio import GpioModels
from ._peripherals import PinModel, has

__all__ = ["FakeMcp3008", "SpiModels"]

E = p.ErrorCode
SPI_PINS = (11, 12, 13)


class FakeMcp3008:
    """An MCP3008 at byte level: the standard 3-byte conversion (``0x01``, SGL/DIFF and
    the channel, a filler) answers the code of ``volts[channel]`` against ``vref``."""

    def __init__(self, volts: Sequence[float] = (0.0,) * 8, vref: float = 5.0) -> None:
        self.volts = list(volts) + [0.0] * (8 - len(volts))
        self.vref = vref

    def code(self, config: int) -> int:
        """The 10-bit code of a conversion: ``config`` is SGL/DIFF, D2, D1, D0."""
        """The 10-bit code of a conversion: ``config`` is SGL/DIFF, D2, D1, D0."""
        sel = config & 7
        # single-ended: CHn; differential: the pair's IN+ minus its IN-
        v = self.volts[sel] if config & 8 else self.volts[sel] - self.volts[sel ^ 1]
        return max(0, min(1023, round(1024 * v / self.vref)))

    def __call__(self, mosi: bytes) -> bytes:
        if len(mosi) < 3 or mosi[0] != 0x01:
            return bytes(len(mosi))
        code = self.code(mosi[1] >> 4)
        return bytes((0, code >> 8, code & 0xFF)) + bytes(len(mosi) - 3)


class SpiModels(GpioModels):
    """SPI CONFIG/TRANSFER (mixed into the FakeBoard)."""

    def _spi_handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        """The SPI class's request models, for the board's handler table."""
        self.spi_device: Callable[[bytes], bytes] = bytes
        #: (bytes sent, bytes received) of every transfer.
        self.spi_frames: list[tuple[bytes, bytes]] = []
        #: The bridge's CONFIG while it is on, else None.
        self.spi_config: p.SpiConfig | None = None
        return {p.SpiConfig: self._spi_config, p.SpiTransfer: self._spi_transfer}

    def _release(self, request: p.PinRelease) -> p.Frame:
        config = self.spi_config
        if config is not None and request.pin in (*SPI_PINS, config.cs):
            self._spi_off()
        return super()._release(request)

    def _spi_off(self) -> None:
        config, self.spi_config = self.spi_config, None
        if config is not None:
            for pin in (*SPI_PINS, config.cs):
                self._pins[pin] = PinModel()

    def _spi_config(self, request: p.SpiConfig) -> p.Frame:
        if not has(self._mask(Function.SPI_CS), request.cs):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if request.mode > 3 or request.clock > max(p.SpiClock) or request.order > 1:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        for pin in (*SPI_PINS, request.cs):
            if self._pins[pin].role not in ("free", "spi"):
                return self._error(request, E.PIN_BUSY)
        old = self.spi_config
        if old is not None and old.cs != request.cs:
            self._pins[old.cs] = PinModel()
        for pin in (*SPI_PINS, request.cs):
            self._pins[pin].role = "spi"
        self.spi_config = request
        return p.SpiConfigReply(request.cs, request.mode, request.clock, request.order)

    def _spi_transfer(self, request: p.SpiTransfer) -> p.Frame:
        if self.spi_config is None:
            return self._error(request, E.SPI_NOT_CONFIGURED)
        if not 1 <= len(request.data) <= p.MAX_BLOB:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        received = bytes(self.spi_device(bytes(request.data)))[: len(request.data)]
        received += bytes(len(request.data) - len(received))
        self.spi_frames.append((bytes(request.data), received))
        return p.SpiTransferReply(received)
