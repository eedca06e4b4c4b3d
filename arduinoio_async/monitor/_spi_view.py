"""The monitor's SPI panel: the bus's settings and a transfer box, like the I2C one.

The SPI bridge is four pins and a request that is neither a level nor a count, so it is a
:class:`~arduinoio_async.monitor._devices.DeviceView`: its row is the bus the board's role
table holds (chip select, mode, clock, bit order) with the last transfer made from the
page; its controls set the bus up, send hex bytes, and release it.  Reading the row sends
nothing to the board (a transfer is an action on the device, never a poll).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .. import protocol as p
from ..board.spi import SpiBus
from ..errors import UsageError
from ..protocol.pins import DigitalPin
from ._devices import Action, DeviceView

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["SpiView"]


class SpiView(DeviceView):
    """The SPI bus: set up on a chip select, transfers in hex, release."""

    key = "spi"
    feature = p.Feature.SPI

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        super().__init__(board, on_change=on_change)
        self._last: tuple[str, str] | None = None

    def bus(self) -> SpiBus | None:
        """The bus in the board's role table, if it has one."""
        for claim in self.board.roles.values():
            if isinstance(claim.handle, SpiBus) and not claim.handle.released:
                return claim.handle
        return None

    async def read_rows(self) -> list[dict[str, object]]:
        bus = self.bus()
        if bus is None:
            return []
        row: dict[str, object] = {
            "cs": bus.pin.name,
            "mode": bus.mode,
            "clock_hz": bus.clock_hz,
            "lsb_first": bus.order == p.SpiBitOrder.LSB_FIRST,
        }
        if self._last is not None:
            row["sent"], row["received"] = self._last
        return [row]

    def actions(self) -> dict[str, Action]:
        return {"spi": self._set_up, "spi_transfer": self._transfer, "spi_release": self._release}

    async def _set_up(self, args: Mapping[str, Any]) -> str:
        """``{"cs": "D10", "mode": 0, "clock_hz": 1000000}``: the bus; answers its words."""
        try:
            cs = DigitalPin[str(args.get("cs", "D10"))]
        except KeyError:
            raise UsageError("cs must be a digital pin name such as D10") from None
        bus = await self.board.spi(
            cs,  # type: ignore[arg-type]  # checked at run time: PinCapabilityError
            mode=int(args.get("mode", 0)),
            clock_hz=int(args.get("clock_hz", 1_000_000)),
            bit_order="lsb" if args.get("lsb_first") else "msb",
        )
        self._last = None
        await self.read()
        return repr(bus)

    async def _transfer(self, args: Mapping[str, Any]) -> str:
        """``{"data": "01 80 00"}``: one transfer; answers the bytes received, in hex."""
        bus = self.bus()
        if bus is None:
            raise UsageError("set the SPI bus up first")
        try:
            data = bytes.fromhex(str(args["data"]))
        except ValueError:
            raise UsageError(f"not hex bytes: {args['data']!r} (write them as 01 80 00)") from None
        received = await bus.transfer(data)
        self._last = (data.hex(" "), received.hex(" "))
        await self.read()
        return received.hex(" ")

    async def _release(self, args: Mapping[str, Any]) -> None:
        """The bus ends; its four pins become free."""
        bus = self.bus()
        if bus is not None:
            await bus.release()
        self._last = None
        await self.read()
