"""Choosing the board a command talks to: ``--port P`` or ``--id N`` (found by scanning)."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from ..board import Board
from ..manager import BoardManager
from ..network.options import add_remote_options, remote_board
from ..protocol import DEFAULT_BAUD


def board_id(text: str) -> int:
    value = int(text, 0)
    if not 0 <= value <= 0xFFFF:
        raise argparse.ArgumentTypeError(f"board ID must be 0x0000-0xFFFF, got {text}")
    return value


def add_scan_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--ports",
        action="append",
        default=[],
        metavar="PATH_OR_GLOB",
        help="also probe these ports (repeatable; ARDUINOIO_PORTS works too)",
    )
    parser.add_argument("--baud", type=int, default=DEFAULT_BAUD)
    parser.add_argument(
        "--probe-timeout", type=float, default=5.0, help="seconds per port (auto-reset)"
    )


def add_target_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--port", help="serial port or pyserial URL of the board")
    group.add_argument("--id", type=board_id, help="board ID to look for on all ports")
    add_scan_options(parser)
    add_remote_options(parser)


def manager_for(args: argparse.Namespace) -> BoardManager:
    return BoardManager(
        patterns=args.ports,
        baudrate=args.baud,
        probe_deadline=args.probe_timeout,
        rescan_interval=None,
    )


@asynccontextmanager
async def target_board(args: argparse.Namespace) -> AsyncIterator[Board]:
    """The board named by ``--port`` or ``--id``."""
    if getattr(args, "remote", False):
        async with remote_board(args) as b:
            yield b
        return
    if args.port:
        async with Board.open(args.port, baudrate=args.baud, ready_timeout=args.probe_timeout) as b:
            yield b
        return
    async with manager_for(args) as boards:
        yield await boards.get(args.id, timeout=0)
