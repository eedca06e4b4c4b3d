"""``arduinoio encoder A B``: watch a quadrature encoder from the command line.

``arduinoio encoder D2 D3 --seconds 5`` sets up an encoder on the board and prints its count,
direction, speed (from the board's edge times) and invalid transitions every
``--interval`` seconds, then releases both pins.  Wiring: docs/sensors.md.
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from ..board.encoders import encoder_mode
from ..errors import UsageError
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands"]


def add_commands(sub: Any) -> None:
    """Add ``encoder`` to the ``arduinoio`` command line."""
    enc = sub.add_parser("encoder", help="count a quadrature encoder (A and B on any two pins)")
    enc.add_argument("a", type=digital_pin, help="channel A (D2-D13)")
    enc.add_argument("b", type=digital_pin, help="channel B (D2-D13)")
    enc.add_argument("--mode", default="x4", help="x4 (every edge), x2 (edges of A), x1")
    enc.add_argument("--seconds", type=float, default=5.0, help="how long to watch")
    enc.add_argument("--interval", type=float, default=0.5, help="seconds between lines")
    enc.set_defaults(handler=watch_encoder)
    add_target_options(enc)


async def watch_encoder(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio encoder A B [--mode x4] [--seconds S] [--interval I]``."""
    if not args.interval > 0 or not args.seconds >= 0:
        raise UsageError("--interval must be positive and --seconds not negative")
    mode = encoder_mode(args.mode)
    async with target_board(args) as target:
        enc = await target.board.encoder(a=args.a, b=args.b, mode=mode)
        try:
            before = await enc.read()
            console.print(f"encoder {args.a.name}/{args.b.name} x{int(mode)}: count {before.count}")
            for _ in range(round(args.seconds / args.interval)):
                await anyio.sleep(args.interval)
                now = await enc.read()
                velocity = now.velocity_since(before)
                way = "forward" if velocity > 0 else "back" if velocity < 0 else "still"
                console.print(
                    f"count {now.count:+d}  {velocity:+.1f} counts/s ({way})  invalid {now.invalid}"
                )
                before = now
        finally:
            with anyio.CancelScope(shield=True):
                await enc.release()
    return 0
