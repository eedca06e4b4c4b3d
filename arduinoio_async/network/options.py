"""The board commands' ``--remote`` option (importable without Zenoh installed)."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from ..board import Board
from ..errors import UsageError

__all__ = ["add_remote_options", "remote_board"]


def add_remote_options(parser: argparse.ArgumentParser) -> None:
    """``--remote`` (with ``--id``): talk to a board served by ``arduinoio serve``."""
    parser.add_argument(
        "--remote", action="store_true", help="the board (--id) is served on the network"
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="with --remote: Zenoh endpoint of the server (default tcp/127.0.0.1:7447)",
    )
    parser.add_argument("--zenoh-config", type=Path, help="with --remote: Zenoh JSON5 config")


@asynccontextmanager
async def remote_board(args: argparse.Namespace) -> AsyncIterator[Board]:
    """The board ``--id`` served on the network (the CLI's ``--remote``)."""
    if args.id is None:
        raise UsageError("--remote needs --id (the board's ID, e.g. --id 0x0007)")
    from ._client import open_remote_board

    async with open_remote_board(
        args.id,
        connect=args.connect,
        config_file=args.zenoh_config,
        ready_timeout=args.probe_timeout,
    ) as board:
        yield board
