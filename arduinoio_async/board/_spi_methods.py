"""The board's SPI method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea, like ``_encoder_methods.py``: the four pins of the
bus are claimed before anything is sent, each refused with :class:`PinRoleError` naming
its other user, and withdrawn if the board refuses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import PinRoleError, UsageError, ValueRangeError
from ..protocol.pins import DigitalPin, Function, SpiCsPin
from .handles import PinHandle
from .spi import BitOrderName, SpiBus, spi_clock

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["SpiMethods"]

#: Roles that leave D10 (the AVR's SS) an input: a low level there would throw the SPI
#: unit out of master mode, so the bus is refused while D10 has one of them.
_INPUT_ROLES = ("digital input", "event counter", "quadrature encoder")


def _bus_of(board: BoardCore) -> SpiBus | None:
    for claim in board.roles.values():
        if isinstance(claim.handle, SpiBus) and not claim.handle.released:
            return claim.handle
    return None


class SpiMethods:
    """``board.spi()``: the SPI master bridge."""

    async def spi(
        self,
        cs: SpiCsPin,
        *,
        mode: int = 0,
        clock_hz: int = 1_000_000,
        bit_order: BitOrderName = "msb",
    ) -> SpiBus:
        """The SPI master on D11 (MOSI), D12 (MISO), D13 (SCK) with chip select ``cs``.

        ``mode``: 0-3 (CPOL << 1 | CPHA); ``clock_hz``: 8 MHz, 4 MHz, ... 125 kHz (the
        AVR's dividers at 16 MHz; others are refused); ``bit_order``: ``"msb"`` or
        ``"lsb"`` first.  One bus per board.  Raises PinCapabilityError (``cs`` on D11-D13),
        PinRoleError (a pin held by another role, named), ValueRangeError, or
        FirmwareFeatureError on an image without SPI.
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.SPI, "the SPI bridge")
        board.model.require(cs, Function.SPI_CS)
        assert isinstance(cs, DigitalPin)
        if isinstance(mode, bool) or mode not in (0, 1, 2, 3):
            raise ValueRangeError("SPI mode", mode, "0, 1, 2 or 3")
        clock = spi_clock(clock_hz)
        if bit_order not in ("msb", "lsb"):
            raise ValueRangeError("SPI bit order", bit_order, '"msb" or "lsb"')
        order = p.SpiBitOrder.LSB_FIRST if bit_order == "lsb" else p.SpiBitOrder.MSB_FIRST
        if _bus_of(board) is not None:
            raise UsageError(f"the SPI bridge of {board} is already set up: release it first")
        ss = board.roles.holder(DigitalPin.D10)
        if cs is not DigitalPin.D10 and ss is not None and ss.ROLE in _INPUT_ROLES:
            raise PinRoleError("D10", f"{ss.ROLE} (the AVR's SS must not be an input)", "SPI")
        bus = SpiBus(board, cs, mode, clock, order)
        holders: tuple[PinHandle, ...] = (bus, *bus.partners)
        roles = board.roles
        for holder in holders:
            roles.check_free(holder)
        setup = bus.setup
        claimed: list[PinHandle] = []
        try:
            for holder in holders:
                roles.claim(holder, setup)
                claimed.append(holder)
            await board.request(setup)
        except BaseException:
            for holder in reversed(claimed):
                roles.withdraw(holder, None)
            raise
        return bus
