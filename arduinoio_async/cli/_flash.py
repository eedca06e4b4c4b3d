"""``arduinoio flash``: write the project firmware through the Uno's bootloader with avrdude.

An Uno's bootloader (optiboot) runs after the reset that opening the port causes (DTR)
and speaks STK500 at 115200 baud (57600 on older boards: ``--baud 57600``).  The firmware
image comes from the package (see ``arduinoio_async._resources``), so this works from a
wheel as well as from a clone.  With ``--id`` the board ID is written to EEPROM after the
flash and verified after a reset.
"""

from __future__ import annotations

import argparse
import re
import shutil
from pathlib import Path
from typing import Any

import anyio
from rich.console import Console

from .. import _resources
from .. import protocol as p
from ..board import Board
from ..errors import ArduinoIOError
from ..manager import candidate_ports
from ..protocol.profiles import DEFAULT_PROFILE, UNO_PROFILES
from ..transport._bridges import MEGA2560_USB_IDS
from ..transport._latency import port_usb_ids
from ._entry import ToolMissing  # exit code 2 (cli/_entry.py)
from ._target import board_id

__all__ = ["ToolMissing", "add_commands", "avrdude_command", "flash_firmware"]

#: Lines of avrdude's output that say what went wrong (its last line is always "done").
_ERROR_LINE = re.compile(
    r"error|not in sync|not responding|can't|cannot|failed|mismatch|timeout|"
    r"does not match|no such file|permission denied|invalid|initiali[sz]ation",
    re.IGNORECASE,
)
#: Harmless on a pseudo-terminal (a virtual Uno): the modem-control ioctls do not exist.
_HARMLESS = re.compile(r"TIOCM[GS]ET")


def add_commands(sub: Any) -> None:
    flash = sub.add_parser(
        "flash",
        help="write the arduinoio firmware to an Uno through its bootloader (avrdude)",
        description="Write the arduinoio firmware to an Arduino Uno through its bootloader "
        "with avrdude (apt-get install avrdude), then optionally store a board ID. The "
        "firmware images ship with the package.",
    )
    flash.add_argument(
        "--port",
        default=None,
        help="serial port of the Uno (default: the only USB serial port that looks like one)",
    )
    flash.add_argument(
        "--id",
        "--set-id",
        dest="set_id",
        metavar="ID",
        type=board_id,
        default=None,
        help="board ID to store in EEPROM after flashing (verified after a reset)",
    )
    flash.add_argument(
        "--firmware-baud",
        type=int,
        choices=_resources.FIRMWARE_BAUDS,
        default=p.DEFAULT_BAUD,
        help="link speed the firmware will use (default %(default)s)",
    )
    flash.add_argument(
        "--profile",
        choices=UNO_PROFILES,
        default=DEFAULT_PROFILE,
        help="which image (docs: firmware profiles): standard (default: encoders, steppers) "
        "or sensing (encoders, sonar, RC inputs, SPI, I2C blocks in the stream; no steppers)",
    )
    flash.add_argument(
        "--board",
        choices=_resources.BOARDS,
        default=None,
        help="uno (optiboot, STK500v1) or mega2560 (its stk500v2 bootloader, avrdude -c wiring; "
        "one image with every class: no --profile); default: a Mega 2560 when the port's USB "
        "IDs are one, else an Uno",
    )
    flash.add_argument("--hex", type=Path, default=None, help="flash this Intel hex file instead")
    flash.add_argument(
        "--baud",
        type=int,
        default=115200,
        help="bootloader speed: 115200 for optiboot (Uno), 57600 for older bootloaders",
    )
    flash.add_argument("--avrdude", default=None, help="avrdude executable (default: from PATH)")
    flash.add_argument(
        "--dry-run", action="store_true", help="print the avrdude command and do nothing"
    )
    flash.add_argument(
        "--probe-timeout",
        type=float,
        default=5.0,
        help="seconds to wait for the flashed firmware to answer (with --id)",
    )
    flash.set_defaults(handler=flash_firmware)


#: Per board: avrdude's part and programmer for its bootloader (the Uno's optiboot speaks
#: STK500v1, "arduino"; the Mega 2560's stk500v2 bootloader is avrdude's "wiring").
_AVRDUDE_TARGET = {"uno": ("atmega328p", "arduino"), "mega2560": ("atmega2560", "wiring")}


def avrdude_command(
    avrdude: str, port: str, image: Path, baud: int, board: str = "uno"
) -> list[str]:
    """The avrdude invocation for the board's bootloader (no chip erase: -D)."""
    part, programmer = _AVRDUDE_TARGET[board]
    return [
        avrdude,
        "-p",
        part,
        "-c",
        programmer,
        "-P",
        port,
        "-b",
        str(baud),
        "-D",
        "-U",
        f"flash:w:{image}:i",
    ]


def _only_port() -> str:
    ports = candidate_ports()
    if len(ports) == 1:
        return ports[0]
    if not ports:
        raise ArduinoIOError(
            "no serial port looks like an Uno: pass --port (e.g. --port /dev/ttyACM0)"
        )
    raise ArduinoIOError(f"several candidate ports ({', '.join(ports)}): pass --port")


def _error_lines(output: str) -> list[str]:
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    errors = [line for line in lines if _ERROR_LINE.search(line) and not _HARMLESS.search(line)]
    return errors or lines[-5:]


def _board_of(port: str) -> str:
    """The board behind ``port`` by its USB IDs: a Mega 2560, else (pty, unknown) an Uno.
    Blocking (sysfs)."""
    return "mega2560" if port_usb_ids(port) in MEGA2560_USB_IDS else "uno"


async def flash_firmware(args: argparse.Namespace, console: Console) -> int:
    port = args.port or _only_port()
    board = args.board or await anyio.to_thread.run_sync(_board_of, port)
    image = args.hex
    if image is None:
        try:
            image = _resources.firmware_image(args.firmware_baud, "hex", args.profile, board=board)
        except _resources.ResourceNotFound as exc:
            raise ToolMissing(str(exc)) from exc
        except ValueError as exc:  # a profile for the Mega's one image
            raise ArduinoIOError(str(exc)) from exc
    elif not image.is_file():
        raise ToolMissing(f"{image} does not exist")
    avrdude = shutil.which(args.avrdude or "avrdude")
    if avrdude is None and args.avrdude:
        raise ToolMissing(f"--avrdude {args.avrdude}: no such executable program")
    if avrdude is None:
        raise ToolMissing("avrdude is not installed: sudo apt-get install avrdude")
    command = avrdude_command(avrdude, port, image, args.baud, board)
    if args.dry_run:
        console.print(" ".join(command), highlight=False, soft_wrap=True)
        return 0
    with console.status(f"flashing {image.name} to {port} ..."):
        result = await anyio.run_process(command, check=False)
    output = result.stderr.decode(errors="replace") + result.stdout.decode(errors="replace")
    if result.returncode != 0:
        detail = "\n  ".join(_error_lines(output))
        raise ArduinoIOError(f"avrdude failed (exit {result.returncode}):\n  {detail}")
    written = re.search(r"(\d+) bytes of flash verified", output)
    size = f"{written.group(1)} bytes, verified" if written else "done"
    console.print(f"flashed {image.name} to {port} ({size})", highlight=False)
    if args.set_id is not None:
        await _store_id(
            port,
            args.set_id,
            baud=_image_baud(image, args),
            console=console,
            ready_timeout=args.probe_timeout,
        )
    return 0


def _image_baud(image: Path, args: argparse.Namespace) -> int:
    """The firmware's link speed: from a shipped image's name, else ``--firmware-baud``."""
    match = re.fullmatch(r"arduinoio-(?:[a-z]+-)?(\d+)\.hex", image.name)
    return int(match.group(1)) if match else int(args.firmware_baud)


async def _store_id(
    port: str, new_id: int, *, baud: int, console: Console, ready_timeout: float
) -> None:
    async with Board.open(port, baudrate=baud, ready_timeout=ready_timeout) as board:
        await board.write_id(new_id)
        await board.reset()
        read_back = await board.read_id()
    if read_back != new_id:
        raise ArduinoIOError(f"board answered ID 0x{read_back:04X} after reset, not 0x{new_id:04X}")
    console.print(f"board ID 0x{read_back:04X} stored (verified after reset)", highlight=False)
