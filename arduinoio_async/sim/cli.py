"""``arduinoio sim``: run virtual Unos until interrupted, printing where to connect.

Each board gets one JSON line on stdout (``{"id": 1, "port": "/dev/pts/5", "control": ...,
"baud": ...}``) so scripts can pick the ports up, and is announced in the port registry
(:mod:`arduinoio_async._port_registry`) while it runs, so ``arduinoio info`` and
``BoardManager`` find it without being told the port.  A missing
simulator is reported in one line on stderr with exit code 2 rather than a traceback,
because this is the first thing a new user runs.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
from pathlib import Path
from typing import Any

import anyio

from .._port_registry import announce
from ..protocol import DEFAULT_BAUD, FIRMWARE_BAUDS
from ..protocol.profiles import DEFAULT_PROFILE, UNO_PROFILES
from .harness import SimulatorError, SimulatorNotAvailable
from .virtual_uno import start_virtual_unos

__all__ = ["build_parser", "main"]


def _board_id(text: str) -> int:
    value = int(text, 0)
    if not 0 <= value <= 0xFFFF:
        raise argparse.ArgumentTypeError(f"board ID must be 0..0xFFFF, got {text}")
    return value


def build_parser(prog: str = "arduinoio sim") -> argparse.ArgumentParser:
    """The argument parser, exposed so the top-level ``arduinoio`` command can embed it."""
    p = argparse.ArgumentParser(prog=prog, description="Run virtual Arduino Unos (simavr).")
    p.add_argument(
        "--id",
        dest="ids",
        action="append",
        type=_board_id,
        default=None,
        help="board ID (repeat for several boards; 0x prefix allowed)",
    )
    p.add_argument(
        "--board",
        choices=["uno", "mega2560"],
        default="uno",
        help="the MCU and its image: uno (ATmega328P) or mega2560 (ATmega2560, one image)",
    )
    p.add_argument("--fixture", choices=["open", "loopback", "r2r"], default="open")
    p.add_argument("--baud", type=int, choices=FIRMWARE_BAUDS, default=DEFAULT_BAUD)
    p.add_argument("--fast", action="store_true", help="run unpaced, as fast as possible")
    p.add_argument(
        "--usb-bridge",
        "--bridge",
        dest="usb_bridge",
        choices=["none", "16u2", "ftdi", "ch340"],
        default="none",
        help="model a USB bridge: the Uno's 16U2 (4.096 ms tick), an FTDI (latency timer, "
        "16 ms unless --ftdi-latency-ms), a CH340 (next USB frame)",
    )
    p.add_argument("--ftdi-latency-ms", type=int, default=None, help="the FTDI model's timer")
    p.add_argument("--reset-on-open", action="store_true", help="reset like a real Uno on open")
    p.add_argument("--boot-delay-ms", type=int, default=None)
    p.add_argument("--fault-drop", type=float, default=0.0)
    p.add_argument("--fault-insert", type=float, default=0.0)
    p.add_argument("--fault-flip", type=float, default=0.0)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--r2r-tolerance", type=float, default=None)
    p.add_argument(
        "--profile",
        choices=UNO_PROFILES,
        default=DEFAULT_PROFILE,
        help="which firmware image to run (docs: firmware profiles): standard (encoders, "
        "steppers) or sensing (encoders, sonar, RC inputs, SPI, I2C blocks in the stream)",
    )
    p.add_argument(
        "--elf",
        type=Path,
        default=None,
        help="firmware ELF (default: the project firmware for --baud; "
        "with --bootloader: an erased application flash)",
    )
    p.add_argument(
        "--bootloader",
        type=Path,
        default=None,
        metavar="HEX",
        help="boot this bootloader (e.g. optiboot at 0x7C00) from its boot section; the board "
        "resets into it when the port is opened, so `arduinoio flash` and avrdude work",
    )
    return p


async def _run(args: argparse.Namespace) -> None:
    options: dict[str, Any] = {
        "fixture": args.fixture,
        "baud": args.baud,
        "fast": args.fast,
        "usb_bridge": args.usb_bridge,
        "ftdi_latency_ms": args.ftdi_latency_ms,
        "reset_on_open": args.reset_on_open,
        "boot_delay_ms": args.boot_delay_ms,
        "fault_drop": args.fault_drop,
        "fault_insert": args.fault_insert,
        "fault_flip": args.fault_flip,
        "seed": args.seed,
        "r2r_tolerance": args.r2r_tolerance,
        "elf": args.elf,
        "profile": args.profile,
        "board": args.board,
        "bootloader": args.bootloader,
    }
    ids: list[int | None] = list(args.ids) if args.ids else [None]
    with anyio.open_signal_receiver(signal.SIGINT, signal.SIGTERM) as signals:
        async with start_virtual_unos(ids, **options) as boards:
            lines = [
                {
                    "id": board.board_id,
                    "port": board.port,
                    "control": board.control_path,
                    "baud": board.baud,
                }
                for board in boards
            ]
            # Announced while they run (before their lines are printed, so a script that
            # reads the line finds the board), for `arduinoio info` and BoardManager.
            with announce(lines):
                for line in lines:
                    print(json.dumps(line), flush=True)
                async with anyio.create_task_group() as tg:

                    async def watch(board_index: int) -> None:
                        board = boards[board_index]
                        await board.wait_exited()
                        raise SimulatorError(f"virtual Uno {board.board_id} exited unexpectedly")

                    for i in range(len(boards)):
                        tg.start_soon(watch, i)
                    async for _ in signals:
                        tg.cancel_scope.cancel()
                        break


def main(argv: list[str] | None = None) -> int:
    """Entry point: 0 after Ctrl-C/SIGTERM, 2 when the simulator is unavailable, 1 on failure."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.ftdi_latency_ms is not None and (
        args.usb_bridge != "ftdi" or not 1 <= args.ftdi_latency_ms <= 255
    ):
        parser.error("--ftdi-latency-ms needs --usb-bridge ftdi and 1..255 ms")
    try:
        anyio.run(_run, args)
    except SimulatorNotAvailable as exc:
        print(f"arduinoio sim: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0
    except (SimulatorError, ExceptionGroup) as exc:
        first = exc.exceptions[0] if isinstance(exc, ExceptionGroup) else exc
        if isinstance(first, SimulatorNotAvailable):
            print(f"arduinoio sim: {first}", file=sys.stderr)
            return 2
        print(f"arduinoio sim: {first}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
