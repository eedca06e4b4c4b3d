"""Choosing the board a command talks to: ``--port P``, ``--id N``, or the only one there is.

On a bench there is usually one Uno plugged in, so neither option is needed: the ports
are probed and, when exactly one board answers, that is the board.  Several boards: the
error lists them (ID and port) so the next command can name one.  No candidate port at
all: the command fails at once and says how to name ports, instead of waiting for nothing.
"""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass

from ..board import Board
from ..errors import ArduinoIOError, BoardError
from ..manager import BoardManager, candidate_ports
from ..network.options import add_remote_options, remote_board
from ..scan_options import add_scan_options, board_id
from ._roles import explain_busy_pin

__all__ = [
    "NO_PORTS_HINT",
    "Target",
    "add_scan_options",
    "add_target_options",
    "board_id",
    "manager_for",
    "require_candidates",
    "target_board",
]

NO_PORTS_HINT = (
    "no candidate ports: plug in an Uno (USB) or start a virtual one (`arduinoio sim`), "
    "or name ports with --ports PATH_OR_GLOB or ARDUINOIO_PORTS (paths or globs "
    "separated by ':' or ',')"
)


def add_target_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--port", help="serial port or pyserial URL of the board (default: the only board)"
    )
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


def require_candidates(args: argparse.Namespace) -> list[str]:
    """The ports a scan would probe; none at all is an error with the hint, at once."""
    ports = candidate_ports(patterns=args.ports)
    if not ports:
        raise ArduinoIOError(NO_PORTS_HINT)
    return ports


@dataclass
class Target:
    """The chosen board, and the manager that found it (None when opened by ``--port``)."""

    board: Board
    args: argparse.Namespace
    manager: BoardManager | None = None

    async def boards_elsewhere(self) -> dict[int, str]:
        """ID -> port of every *other* board that answers (for duplicate-ID checks)."""
        if self.manager is not None:
            return {
                bid: board.port
                for bid, board in self.manager.present().items()
                if board is not self.board
            }
        others = [
            port for port in candidate_ports(patterns=self.args.ports) if port != self.board.port
        ]
        if not others:
            return {}
        async with BoardManager(
            ports=others,
            usb=False,
            env=False,
            registered=False,
            baudrate=self.args.baud,
            probe_deadline=self.args.probe_timeout,
            rescan_interval=None,
        ) as boards:
            return {bid: board.port for bid, board in boards.present().items()}


def _only_board(boards: BoardManager) -> Board:
    present = boards.present()
    if len(present) == 1:
        return next(iter(present.values()))
    if present:
        listing = ", ".join(
            f"0x{bid:04X} on {board.port}" for bid, board in sorted(present.items())
        )
        raise ArduinoIOError(
            f"{len(present)} boards answered ({listing}): pick one with --id or --port"
        )
    tried = {port: result.error or "no answer" for port, result in boards.probed().items()}
    listing = "; ".join(f"{port}: {why}" for port, why in sorted(tried.items()))
    raise ArduinoIOError(f"no board answered (tried {listing})")


@asynccontextmanager
async def _explained(board: Board) -> AsyncIterator[None]:
    """A refusal because a pin is busy gets the role the board says holds the pin."""
    try:
        yield
    except BoardError as exc:
        if getattr(exc.code, "name", "") != "PIN_BUSY":
            raise
        raise await explain_busy_pin(board, exc) from exc


@asynccontextmanager
async def target_board(args: argparse.Namespace) -> AsyncIterator[Target]:
    """The board named by ``--port`` or ``--id``, or the only board that answers."""
    if getattr(args, "remote", False):
        async with remote_board(args) as remote, _explained(remote):
            yield Target(remote, args)
        return
    if args.port:
        opened = Board.open(args.port, baudrate=args.baud, ready_timeout=args.probe_timeout)
        async with opened as board, _explained(board):
            yield Target(board, args)
        return
    require_candidates(args)
    async with manager_for(args) as boards:
        if args.id is not None:
            board = await boards.get(args.id, timeout=0)
        else:
            board = _only_board(boards)
        async with _explained(board):
            yield Target(board, args, boards)
