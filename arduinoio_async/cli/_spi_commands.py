"""``arduinoio spi --cs D10 transfer 01 80 00``: one SPI transaction from the command line.

Sets up the SPI bridge (D11 MOSI, D12 MISO, D13 SCK, the chip select ``--cs``), sends the
bytes given in hex under one chip select, prints the bytes the device sent back, and
releases the four pins.  Wiring: docs/sensors.md, "SPI bridge".
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from ..errors import UsageError
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands", "hex_bytes"]


def hex_bytes(words: list[str]) -> bytes:
    """``["01", "8000"]`` -> ``b"\\x01\\x80\\x00"``; anything else is a one-line error."""
    try:
        data = b"".join(bytes.fromhex(word) for word in words)
    except ValueError:
        raise UsageError(f"not hex bytes: {' '.join(words)!r} (write them as 01 80 00)") from None
    if not data:
        raise UsageError("give the bytes to send, in hex (01 80 00)")
    return data


def add_commands(sub: Any) -> None:
    """Add ``spi`` to the ``arduinoio`` command line."""
    spi = sub.add_parser("spi", help="exchange bytes with an SPI device (D11-D13 and --cs)")
    spi.add_argument("--cs", type=digital_pin, default="D10", help="chip select (D2-D10)")
    spi.add_argument("--mode", type=int, default=0, help="SPI mode 0-3")
    spi.add_argument(
        "--clock", type=int, default=1_000_000, help="Hz: 8000000, 4000000, ... 125000"
    )
    spi.add_argument("--lsb-first", action="store_true", help="send each byte LSB first")
    actions = spi.add_subparsers(dest="spi_action", required=True)
    transfer = actions.add_parser("transfer", help="send hex bytes, print what comes back")
    transfer.add_argument("data", nargs="+", help="bytes in hex: 01 80 00")
    spi.set_defaults(handler=spi_transfer)
    add_target_options(spi)


async def spi_transfer(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio spi [--cs D10] [--mode M] [--clock HZ] [--lsb-first] transfer HEX...``."""
    data = hex_bytes(args.data)
    async with target_board(args) as target:
        bus = await target.board.spi(
            args.cs,
            mode=args.mode,
            clock_hz=args.clock,
            bit_order="lsb" if args.lsb_first else "msb",
        )
        try:
            received = await bus.transfer(data)
            console.print(f"sent     {data.hex(' ')}")
            console.print(f"received {received.hex(' ')}")
        finally:
            with anyio.CancelScope(shield=True):
                await bus.release()
    return 0
