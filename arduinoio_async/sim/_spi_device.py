"""The virtual Uno's MCP3008 on its SPI pins (``firmware/sim/spi_device.c``).

Mixed into :class:`~arduinoio_async.sim.VirtualUno`: ``await uno.spi_device(cs=10,
volts=[1.0, 2.5])`` puts an MCP3008 (8-channel 10-bit ADC) on D11-D13 with its chip select
on ``cs``, its channels at the given voltages; :meth:`SpiDeviceMethods.spi_device_status`
gives the ground truth the tests compare the board's answers with: the chip select's
edges, the bytes exchanged under each chip select, and the SPI unit's settings (clock
polarity and phase, bit order, clock) at the last byte.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["SpiDeviceMethods", "SpiDeviceStatus", "SpiFrame"]


@dataclass(frozen=True, slots=True)
class SpiFrame:
    """The bytes of one transaction (chip select low to high), as the device saw them."""

    mosi: bytes
    miso: bytes


@dataclass(frozen=True, slots=True)
class SpiDeviceStatus:
    """The device's ground truth since it was put on the bus."""

    cs: int
    cs_low: bool
    cs_falls: int
    cs_rises: int
    #: Bytes the SPI unit clocked, and those of them with the chip select high (ignored).
    bytes: int
    bytes_outside_cs: int
    conversions: int
    transactions: int
    #: The last 16 transactions, oldest first.
    frames: tuple[SpiFrame, ...]
    #: The SPI unit's settings at the last byte (None before the first).
    cpol: int | None = None
    cpha: int | None = None
    lsb_first: int | None = None
    clock_hz: int | None = None
    master: int | None = None

    @property
    def mode(self) -> int | None:
        """SPI mode 0-3 (CPOL << 1 | CPHA) at the last byte."""
        if self.cpol is None or self.cpha is None:
            return None
        return self.cpol << 1 | self.cpha


class SpiDeviceMethods:
    """The MCP3008 model's commands: ``spi_device`` and ``spi_device_status``."""

    async def command(self, cmd: str, **params: Any) -> dict[str, Any]:
        """One control-channel command (VirtualUno's)."""
        raise NotImplementedError

    async def spi_device(
        self,
        *,
        cs: int | None = None,
        volts: Sequence[float] | dict[int, float] = (),
        vref: float | None = None,
    ) -> None:
        """Put an MCP3008 on the bus (chip select ``cs`` 2-10, -1: none), set its channels.

        ``volts``: channel voltages from CH0 (a sequence) or by channel (a dict); channels
        not named keep theirs.  Naming ``cs`` restarts the ground-truth counters.
        """
        params: dict[str, Any] = {}
        if cs is not None:
            params["cs"] = cs
        if vref is not None:
            params["vref"] = vref
        items = volts.items() if isinstance(volts, dict) else enumerate(volts)
        for channel, value in items:
            params[f"ch{channel}"] = float(value)
        reply = await self.command("spi_device", **params)
        if not reply.get("ok", False):
            raise ValueError(reply.get("error", "spi_device refused"))

    async def spi_device_status(self) -> SpiDeviceStatus:
        """The device's ground truth."""
        reply = dict(await self.command("spi_device_status"))
        reply.pop("ok", None)
        reply.pop("spe", None)
        frames = tuple(SpiFrame(bytes(f["mosi"]), bytes(f["miso"])) for f in reply.pop("frames"))
        return SpiDeviceStatus(frames=frames, **reply)
