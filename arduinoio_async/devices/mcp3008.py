"""MCP3008: an 8-channel 10-bit ADC on the SPI bridge.

Wiring (docs/sensors.md, "SPI bridge"): VDD and VREF to 5 V, AGND/DGND to GND, CLK to
D13, DOUT to D12, DIN to D11, CS/SHDN to the chip select (D10 by default).  One conversion
is one 3-byte transfer (datasheet, section 6.1, "using the MCP3008 with MCU SPI ports"):
``0x01`` (the start bit, last), then SGL/DIFF and the channel in the upper nibble, then
a filler; the answer's last 10 bits are the code.  The part takes SPI mode 0 or 3, MSB
first, up to 3.6 MHz at 5 V (1.35 MHz at 2.7 V): 1 MHz by default.

``adc = await MCP3008.open(board, cs=D10)``; ``await adc.read_channel(3)`` -> volts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin, SpiCsPin

if TYPE_CHECKING:
    from ..board.board import Board
    from ..board.spi import SpiBus

__all__ = ["MCP3008"]

#: Codes of the 10-bit converter: 0 to 1023.
FULL_SCALE = 1024


class MCP3008:
    """An MCP3008 on ``bus`` with reference voltage ``vref`` (volts)."""

    def __init__(self, bus: SpiBus, vref: float = 5.0) -> None:
        if not vref > 0:
            raise ValueRangeError("MCP3008 reference voltage", vref, "above 0 V")
        if bus.mode not in (0, 3) or bus.order != 0:
            raise ValueRangeError("MCP3008 bus settings", repr(bus), "SPI mode 0 or 3, MSB first")
        self.bus = bus
        self.vref = vref

    @classmethod
    async def open(
        cls,
        board: Board,
        cs: SpiCsPin = DigitalPin.D10,
        *,
        clock_hz: int = 1_000_000,
        vref: float = 5.0,
    ) -> MCP3008:
        """Set up the SPI bridge for the part (mode 0, MSB first) and return its driver."""
        return cls(await board.spi(cs, mode=0, clock_hz=clock_hz), vref)

    @staticmethod
    def request_bytes(channel: int, *, differential: bool = False) -> bytes:
        """The 3 bytes of one conversion of ``channel`` (0-7; differential: the pair
        CH(2k)/CH(2k+1) with ``channel`` = 2k + 1 meaning CH(2k+1) is IN+)."""
        if isinstance(channel, bool) or not isinstance(channel, int) or not 0 <= channel <= 7:
            raise ValueRangeError("MCP3008 channel", channel, "0-7")
        return bytes((0x01, (0x00 if differential else 0x80) | channel << 4, 0x00))

    async def read_code(self, channel: int, *, differential: bool = False) -> int:
        """One conversion: the 10-bit code (0-1023)."""
        reply = await self.bus.transfer(self.request_bytes(channel, differential=differential))
        return (reply[1] & 0x03) << 8 | reply[2]

    async def read_channel(self, channel: int, *, differential: bool = False) -> float:
        """One conversion in volts: code * vref / 1024 (single-ended: CHn against AGND;
        differential: IN+ - IN-, 0 when negative)."""
        code = await self.read_code(channel, differential=differential)
        return code * self.vref / FULL_SCALE
