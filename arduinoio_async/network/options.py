"""The board commands' ``--remote`` option (importable without Zenoh installed)."""

from __future__ import annotations

import argparse
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio

from ..board import Board
from ..errors import ArduinoIOError, UsageError

__all__ = ["add_remote_options", "remote_board", "remote_boards_listing"]


def add_remote_options(
    parser: argparse.ArgumentParser, *, help: str = "the board (--id) is served on the network"
) -> None:
    """``--remote`` (with ``--id``): talk to a board served by ``arduinoio serve``."""
    parser.add_argument("--remote", action="store_true", help=help)
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


async def remote_boards_listing(args: argparse.Namespace) -> list[dict[str, Any]]:
    """``list --remote``: one row per board a server announces, in the rows of ``list``.

    The servers' announcements are asked for once (a liveliness query, which ends when
    every reachable server has answered), then each board is connected like any remote
    board, so a row says "ok" only for a board that answered through its server.
    """
    from ._client import RemoteBoards
    from ._keys import ALL_BOARDS, announcement_from_key

    async with RemoteBoards(
        connect=args.connect, config_file=args.zenoh_config, ready_timeout=args.probe_timeout
    ) as remote:
        session = remote.session
        assert session is not None

        def announcements() -> dict[int, set[str]]:
            found: dict[int, set[str]] = {}
            for reply in session.liveliness().get(ALL_BOARDS, timeout=args.probe_timeout):
                if reply.ok is None:
                    continue
                announced = announcement_from_key(str(reply.ok.key_expr))
                if announced is not None:
                    found.setdefault(announced[0], set()).add(announced[1])
            return found

        rows: list[dict[str, Any]] = []
        for board_id, servers in sorted((await anyio.to_thread.run_sync(announcements)).items()):
            port = f"zenoh://0x{board_id:04X}"
            if len(servers) > 1:
                status = f"served by {len(servers)} servers: the ID names more than one board"
                rows.append({"port": port, "id": board_id, "status": status})
                continue
            try:
                board = await remote.get(board_id, timeout=args.probe_timeout)
            except ArduinoIOError as exc:
                rows.append({"port": port, "id": board_id, "status": str(exc)})
                continue
            caps = board.capabilities
            rows.append(
                {
                    "port": board.port,
                    "id": board.board_id,
                    "firmware": f"{caps.firmware_major}.{caps.firmware_minor}",
                    "protocol": caps.protocol_version,
                    "baud": caps.baud,
                    "status": "ok",
                }
            )
        return rows
