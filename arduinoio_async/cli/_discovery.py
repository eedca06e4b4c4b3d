"""``arduinoio list``, ``info`` and ``status``: which boards answer and what state they are in."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rich.console import Console

from .. import protocol as p
from ..board import Board
from ..network.options import add_remote_options, remote_boards_listing
from ..protocol.boards import BoardModel
from ..protocol.pins import Function
from ..transport import last_tuning
from ._output import print_record, print_rows
from ._roles import pin_roles
from ._target import (
    add_scan_options,
    add_target_options,
    manager_for,
    require_candidates,
    target_board,
)

__all__ = ["add_commands", "board_state"]


def add_commands(sub: Any) -> None:
    listing = sub.add_parser(
        "list",
        help="probe ports and list the boards that answer (exit 1 when none does)",
        description="Probe every candidate port (USB serial devices of Uno bridges, virtual "
        "Unos that `arduinoio sim` runs, --ports, ARDUINOIO_PORTS) and list what answered. "
        "Ports another program holds are skipped and listed as busy. With --remote: the "
        "boards `arduinoio serve` announces.",
    )
    add_scan_options(listing)
    add_remote_options(listing, help="list the boards served on the network (arduinoio serve)")
    listing.add_argument("--json", action="store_true", help="machine-readable output")
    listing.set_defaults(handler=list_boards)
    info = sub.add_parser(
        "info",
        help="ID, versions, capabilities, pin roles, failsafe, stream and temperature of a board",
    )
    add_target_options(info)
    info.add_argument("--json", action="store_true", help="machine-readable output")
    info.set_defaults(handler=board_info)
    status = sub.add_parser(
        "status", help="pin roles, failsafe (off/armed/tripped) and stream state of a board"
    )
    add_target_options(status)
    status.add_argument("--json", action="store_true", help="machine-readable output")
    status.set_defaults(handler=board_status)


def _features(mask: int) -> list[str]:
    return [str(f.name).lower() for f in p.Feature if f.name and mask & f]


async def list_boards(args: argparse.Namespace, console: Console) -> int:
    if args.remote:
        with console.status("asking the servers..."):
            rows = await remote_boards_listing(args)
        if not rows:
            print("no board is served at the endpoints asked", file=sys.stderr)
            return 1
        return _print_listing(console, rows, args.json)
    require_candidates(args)
    with console.status("probing ports..."):
        async with manager_for(args) as boards:
            rows = []
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
                            **_bridge_cell(port),
                            "status": "ok",
                        }
                    )
                else:
                    status = result.error or "not answering"
                    rows.append(
                        {
                            "port": port,
                            "id": result.board_id,
                            **_bridge_cell(port),
                            "status": status,
                        }
                    )
    return _print_listing(console, rows, args.json)


def _print_listing(console: Console, rows: list[dict[str, Any]], as_json: bool) -> int:
    """The table (or JSON) of ``list``; exit code 1 when no board answered."""
    shown = [
        {**{key: str(value) for key, value in row.items()}, "id": _hex_id(row.get("id"))}
        for row in rows
    ]
    columns = [
        ("port", "port"),
        ("id", "board ID"),
        ("firmware", "firmware"),
        ("protocol", "protocol"),
        ("baud", "baud"),
        ("status", "status"),
        ("bridge", "USB bridge"),
    ]
    print_rows(console, "arduinoio boards", columns, rows, as_json=as_json, shown=shown)
    if not any(row["status"] == "ok" for row in rows):
        print(f"no board answered on {len(rows)} port(s)", file=sys.stderr)
        return 1
    return 0


def _bridge_cell(port: str) -> dict[str, str]:
    """``list``'s USB bridge column (absent without a bridge): the bridge's kind, and a
    pointer to ``info`` when the fastest link could not be set (an FTDI's timer)."""
    tuning = last_tuning(port)
    if tuning is None or tuning.bridge is None:
        return {}
    if tuning.problem:
        return {"bridge": f"{tuning.bridge.kind}: latency timer not lowered (`arduinoio info`)"}
    return {"bridge": tuning.bridge.kind}


def _usb_bridge(port: str) -> tuple[dict[str, str] | None, str | None]:
    """The bridge ``port`` is on and what opening it set (raw, shown); (None, None) for a
    port this process did not open as a serial port (a network board)."""
    tuning = last_tuning(port)
    if tuning is None:
        return None, None
    if tuning.bridge is None:
        return {}, "none (no USB device: a pseudo-terminal, a URL or an on-board UART)"
    raw = {
        "kind": tuning.bridge.kind,
        "name": tuning.bridge.name,
        "set": tuning.applied,
        "problem": tuning.problem,
    }
    return raw, f"{tuning.bridge.name}: {tuning.problem or tuning.applied or 'nothing to set'}"


def _hex_id(value: object) -> str:
    return f"0x{value:04X}" if isinstance(value, int) else "-"


async def board_state(board: Board) -> dict[str, Any]:
    """What the board reports about itself now (``status``; also part of ``info``)."""
    status = await board.status()
    flags = status.flags
    if flags & p.StatusFlags.FAILSAFE_TRIPPED:
        failsafe = "tripped"
    elif flags & p.StatusFlags.FAILSAFE_ARMED:
        failsafe = "armed"
    else:
        failsafe = "off"
    return {
        "port": board.port,
        "id": board.board_id,
        "failsafe": failsafe,
        "stream": "running" if flags & p.StatusFlags.STREAMING else "stopped",
        "session_found": board.session_found,
        "session": status.session,
        "pins": await pin_roles(board),
    }


def _state_text(state: dict[str, Any]) -> dict[str, str]:
    failsafe = state["failsafe"]
    if failsafe == "tripped":
        failsafe = "TRIPPED: outputs held in their safe states (`arduinoio failsafe --clear`)"
    elif failsafe == "armed":
        failsafe = "armed (trips when the host goes silent)"
    pins = ", ".join(f"{pin} {role}" for pin, role in state["pins"].items())
    found = state["session_found"]
    return {
        "failsafe": failsafe,
        "stream": state["stream"],
        "session": (
            "0x0000 when this command connected: a fresh boot, no program had tagged it"
            if found == 0
            else f"0x{found:04X} when this command connected: tagged by an earlier program, "
            "no reset since"
        ),
        "pin roles": pins or "none (every pin free)",
    }


def _model_raw(model: BoardModel) -> dict[str, object]:
    """The board's model for --json: key, name, MCU and pin names per function."""
    return {
        "key": model.key,
        "name": model.name,
        "mcu": model.mcu,
        "pins": {f.name.lower(): list(model.pin_names(f)) for f in Function},
    }


async def board_info(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        caps = board.capabilities
        state = await board_state(board)
        # the ATmega2560 has no temperature sensor: its image does not offer the reading
        sensor = bool(caps.features & p.Feature.TEMPERATURE)
        raw = {
            **state,
            "firmware": f"{caps.firmware_major}.{caps.firmware_minor}",
            "protocol": caps.protocol_version,
            "baud": caps.baud,
            "rx_buffer": caps.rx_buffer,
            "features": _features(caps.features),
            "temperature_c": round(await board.temperature(), 1) if sensor else None,
            "model": _model_raw(board.model),
        }
    bridge_raw, bridge_shown = _usb_bridge(board.port)
    if bridge_raw is not None:
        raw["usb_bridge"] = bridge_raw or None
    shown = {
        "board ID": f"0x{board.board_id:04X}",
        "port": board.port,
        **({"USB bridge": bridge_shown} if bridge_shown else {}),
        "firmware": raw["firmware"],
        "protocol": str(caps.protocol_version),
        "baud": str(caps.baud),
        "receive FIFO": f"{caps.rx_buffer} bytes",
        "features": ", ".join(raw["features"]),
        **_state_text(state),
        "temperature": f"{raw['temperature_c']:.1f} C" if sensor else "no sensor",
        "model": f"{board.model.name} ({board.model.mcu})",
        **{f"pins: {f.value}": board.model.pin_ranges(f) for f in Function},
    }
    print_record(console, f"board on {board.port}", shown, raw=raw, as_json=args.json)
    return 0


async def board_status(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        state = await board_state(target.board)
    shown = {"board ID": _hex_id(state["id"]), "port": state["port"], **_state_text(state)}
    print_record(console, f"board on {state['port']}", shown, raw=state, as_json=args.json)
    return 0
