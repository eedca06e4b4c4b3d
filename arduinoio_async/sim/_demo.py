"""Where an example's board is: the port it was given, or a virtual Uno started for it.

Every program in ``examples/`` takes ``--port`` (a real Uno's ``/dev/ttyACM0``, or a port
the test suite started) and, without one, runs against a virtual Uno of its own, so a new
user can try each example before any hardware arrives.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from .. import protocol as p
from ..board import Board
from ..protocol.profiles import DEFAULT_PROFILE
from .virtual_uno import Fixture, VirtualUno

__all__ = ["example_arguments", "example_board", "port_or_virtual_uno"]


def example_arguments(description: str | None) -> argparse.ArgumentParser:
    """An argument parser with ``--port`` and ``--baud``; examples add their own options."""
    parser = argparse.ArgumentParser(description=(description or "").strip().splitlines()[0])
    parser.add_argument("--port", help="serial port of the board (default: a virtual Uno)")
    parser.add_argument("--baud", type=int, default=p.DEFAULT_BAUD, help="the firmware's baud")
    return parser


@asynccontextmanager
async def port_or_virtual_uno(
    port: str | None,
    *,
    baud: int = p.DEFAULT_BAUD,
    fixture: Fixture = "loopback",
    board_id: int = 1,
    profile: str = DEFAULT_PROFILE,
) -> AsyncIterator[str]:
    """``port`` itself, or the port of a virtual Uno (running the firmware image of
    ``profile``) that runs until the block ends."""
    if port:
        yield port
        return
    async with VirtualUno(board_id=board_id, fixture=fixture, baud=baud, profile=profile) as uno:
        print(f"(no --port given: a virtual Uno on {uno.port})", file=sys.stderr)
        yield uno.port


@asynccontextmanager
async def example_board(
    args: argparse.Namespace,
    *,
    fixture: Fixture = "loopback",
    board_id: int = 1,
    profile: str = DEFAULT_PROFILE,
) -> AsyncIterator[Board]:
    """The board of an example run with ``args`` (from :func:`example_arguments`); without
    ``--port``, a virtual Uno running the firmware image of ``profile``."""
    async with (
        port_or_virtual_uno(
            args.port, baud=args.baud, fixture=fixture, board_id=board_id, profile=profile
        ) as port,
        Board.open(port, baudrate=args.baud) as board,
    ):
        yield board
