"""The SPI bridge: the :class:`SpiBus` handle and its pins.

``bus = await board.spi(cs=D10, mode=0, clock_hz=1_000_000)`` takes the AVR's hardware SPI
master on D11 (MOSI), D12 (MISO) and D13 (SCK) with a chip select on any other digital
pin; ``await bus.transfer(b"\\x01\\x80\\x00")`` pulls the chip select low, exchanges the
bytes full duplex and lets it go high, one device transaction per call
(:mod:`arduinoio_async.protocol.commands.spi`).  All four pins hold the role "SPI" in
:attr:`Board.roles <arduinoio_async.board.Board.roles>`, so a GPIO, servo or counter
there is refused before anything is sent (naming SPI), and SPI is refused while any of
them serves something else.  Releasing the bus (or any of its pins) frees all four.

The clock is one the AVR's divider gives at 16 MHz (:data:`SPI_CLOCKS_HZ`): 8 MHz down to
125 kHz in halvings; any other value is refused rather than rounded, so the clock a
device's datasheet allows is the clock it gets.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin
from .handles import PinHandle

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["SPI_CLOCKS_HZ", "SPI_PINS", "BitOrderName", "SpiBus", "SpiPin", "spi_clock"]

#: MOSI, MISO, SCK: the AVR's SPI unit.
SPI_PINS: tuple[DigitalPin, ...] = (DigitalPin.D11, DigitalPin.D12, DigitalPin.D13)
#: The clocks the board can run, in Hz (16 MHz divided by 2 to 128).
SPI_CLOCKS_HZ: tuple[int, ...] = tuple(clock.hz for clock in p.SpiClock)

BitOrderName = Literal["msb", "lsb"]


def spi_clock(clock_hz: int) -> p.SpiClock:
    """The divider setting of ``clock_hz``, which must be one of :data:`SPI_CLOCKS_HZ`."""
    for clock in p.SpiClock:
        if clock.hz == clock_hz and not isinstance(clock_hz, bool):
            return clock
    listed = ", ".join(f"{hz:_}" for hz in SPI_CLOCKS_HZ)
    raise ValueRangeError("SPI clock (Hz)", clock_hz, f"one of {listed}")


class SpiPin(PinHandle):
    """MOSI, MISO or SCK: it holds its pin in :attr:`Board.roles` for the bus."""

    ROLE = "SPI"

    def __init__(self, board: BoardCore, pin: DigitalPin, bus: SpiBus) -> None:
        super().__init__(board, pin)
        #: The bus this pin serves: releasing the pin ends it (all four pins).
        self.owner = bus

    async def release(self) -> None:
        """End the bus (all four pins)."""
        await self.owner.release()


class SpiBus(PinHandle):
    """The SPI master with its chip select on :attr:`pin`.

    ``mode`` is 0-3 (clock polarity << 1 | clock phase), ``clock_hz`` the SCK frequency,
    ``bit_order`` ``"msb"`` or ``"lsb"`` first.
    """

    ROLE = "SPI"

    def __init__(
        self,
        board: BoardCore,
        cs: DigitalPin,
        mode: int,
        clock: p.SpiClock,
        order: p.SpiBitOrder,
    ) -> None:
        super().__init__(board, cs)
        self.mode = mode
        self.clock = clock
        self.order = order
        self.partners = tuple(SpiPin(board, pin, self) for pin in SPI_PINS)

    def __repr__(self) -> str:
        order = "LSB" if self.order == p.SpiBitOrder.LSB_FIRST else "MSB"
        return (
            f"<SpiBus CS {self.pin.name} mode {self.mode} {self.clock_hz / 1e6:g} MHz "
            f"{order} first on {self.board}>"
        )

    @property
    def clock_hz(self) -> int:
        """The SCK frequency in Hz."""
        return self.clock.hz

    @property
    def other_pins(self) -> tuple[DigitalPin, ...]:
        """MOSI, MISO, SCK: released with the chip select."""
        return SPI_PINS

    @property
    def setup(self) -> p.SpiConfig:
        """The request that sets the bus up (replayed after a reset)."""
        return p.SpiConfig(int(self.pin), self.mode, self.clock, self.order)

    async def transfer(self, data: bytes | bytearray | memoryview) -> bytes:
        """Chip select low, send ``data`` (1-32 bytes), chip select high: the bytes the
        device sent back meanwhile, as many as were sent."""
        self.check_usable()
        out = bytes(data)
        if not 1 <= len(out) <= p.MAX_BLOB:
            raise ValueRangeError("SPI transfer length", len(out), f"1-{p.MAX_BLOB} bytes")
        return (await self.board.request(p.SpiTransfer(out))).received

    async def write(self, data: bytes | bytearray | memoryview) -> None:
        """:meth:`transfer` ignoring what comes back."""
        await self.transfer(data)

    async def read(self, length: int, *, fill: int = 0x00) -> bytes:
        """``length`` bytes (1-32) from the device, sending ``fill`` meanwhile."""
        if not 0 <= fill <= 0xFF:
            raise ValueRangeError("SPI fill byte", fill, "0x00-0xFF")
        if not 1 <= length <= p.MAX_BLOB:
            raise ValueRangeError("SPI read length", length, f"1-{p.MAX_BLOB} bytes")
        return await self.transfer(bytes((fill,)) * length)

    async def release(self) -> None:
        """End the bus on the board; its four pins become free."""
        self.check_usable()
        await self.board.release(self.pin)
