"""``arduinoio list`` and ``arduinoio info``."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rich.console import Console
from rich.table import Table

from .. import protocol as p
from ._target import add_scan_options, add_target_options, manager_for, target_board


def add_commands(sub: Any) -> None:
    listing = sub.add_parser("list", help="probe ports and list the boards that answer")
    add_scan_options(listing)
    listing.add_argument("--json", action="store_true", help="machine-readable output")
    listing.set_defaults(handler=list_boards)
    info = sub.add_parser("info", help="ID, versions, capabilities and temperature of a board")
    add_target_options(info)
    info.set_defaults(handler=board_info)


def _features(mask: int) -> list[str]:
    return [str(f.name).lower() for f in p.Feature if f.name and mask & f]


async def list_boards(args: argparse.Namespace, console: Console) -> int:
    with console.status("probing ports..."):
        async with manager_for(args) as boards:
            rows: list[dict[str, Any]] = []
            present = {board.port: board for board in boards.present().values()}
            for port, result in sorted(boards.probed().items()):
                board = present.get(port)
                if board is not None:
                    caps = board.capabilities
                    rows.append(
                        {
                            "port": port,
                            "id": board.board_id,
                            "firmware": f"{caps.firmware_major}.{caps.firmware_minor}",
                            "protocol": caps.protocol_version,
                            "baud": caps.baud,
                            "status": "ok",
                        }
                    )
                else:
                    status = result.error or "not answering"
                    rows.append({"port": port, "id": result.board_id, "status": status})
    if args.json:
        console.print_json(json.dumps(rows))
        return 0
    table = Table(title="arduinoio boards")
    for column in ("port", "board ID", "firmware", "protocol", "baud", "status"):
        table.add_column(column)
    for row in rows:
        table.add_row(
            row["port"],
            f"0x{row['id']:04X}" if row.get("id") is not None else "-",
            row.get("firmware", "-"),
            str(row.get("protocol", "-")),
            str(row.get("baud", "-")),
            row["status"],
        )
    console.print(table)
    if not rows:
        console.print("no ports to probe: plug in a board, or pass --ports / set ARDUINOIO_PORTS")
    return 0


async def board_info(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as board:
        caps = board.capabilities
        table = Table(show_header=False, title=f"board on {board.port}")
        table.add_row("board ID", f"0x{board.board_id:04X}")
        table.add_row("firmware", f"{caps.firmware_major}.{caps.firmware_minor}")
        table.add_row("protocol", str(caps.protocol_version))
        table.add_row("baud", str(caps.baud))
        table.add_row("receive FIFO", f"{caps.rx_buffer} bytes")
        table.add_row("features", ", ".join(_features(caps.features)))
        table.add_row("temperature", f"{await board.temperature():.1f} C")
        console.print(table)
    return 0
