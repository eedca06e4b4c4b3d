"""The ``arduinoio`` command: bench checks, discovery, IDs, flashing, simulator, benchmark.

Every sub-command is an ``async def`` taking parsed arguments; :func:`main` takes
``argv`` and returns the exit code, so tests call it directly.  Every command, the ones
dispatched to their own modules included, ends through :func:`._entry.run_command`: an
error is one line on stderr and a documented exit code (1 failed, 2 usage or missing
tool/extra, 130 Ctrl-C; ``docs/howto/command-line.md``).  Output piped to a file is not
squeezed to 80 columns (:func:`._entry.make_console`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from rich.console import Console

from ..transport import run as run_event_loop  # uvloop when installed
from . import (
    _board_commands,
    _discovery,
    _encoder_commands,
    _flash,
    _motor_commands,
    _pulse_in_commands,
    _sonar_commands,
    _spi_commands,
    _stepper_commands,
    _stream_commands,
)
from ._entry import make_console, run_command

__all__ = ["main", "run"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arduinoio", description="Arduino Unos as robot I/O boards (arduinoio_async)."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _discovery.add_commands(sub)
    _board_commands.add_commands(sub)
    _motor_commands.add_commands(sub)
    _stepper_commands.add_commands(sub)
    _encoder_commands.add_commands(sub)
    _sonar_commands.add_commands(sub)
    _pulse_in_commands.add_commands(sub)
    _spi_commands.add_commands(sub)
    _stream_commands.add_commands(sub)
    _flash.add_commands(sub)
    sim = sub.add_parser("sim", help="run virtual Unos (simavr) until interrupted", add_help=False)
    sim.add_argument("rest", nargs=argparse.REMAINDER)
    bench = sub.add_parser(
        "bench", help="latency benchmark against the paper's Table IV", add_help=False
    )
    bench.add_argument("rest", nargs=argparse.REMAINDER)
    monitor = sub.add_parser(
        "monitor", help="live page of the boards in the browser", add_help=False
    )
    monitor.add_argument("rest", nargs=argparse.REMAINDER)
    serve = sub.add_parser(
        "serve", help="serve this machine's boards on the network", add_help=False
    )
    serve.add_argument("rest", nargs=argparse.REMAINDER)
    ros2 = sub.add_parser("ros2", help="run the boards as ROS 2 nodes (rmw_zenoh)", add_help=False)
    ros2.add_argument("rest", nargs=argparse.REMAINDER)
    return parser


def main(argv: Sequence[str] | None = None, *, console: Console | None = None) -> int:
    """Run the command line ``argv``; returns the process exit code."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    out = console or make_console()
    return run_command(lambda: _dispatch(args_list, out), make_console(stderr=True))


def _dispatch(args_list: list[str], console: Console) -> int:
    if args_list[:1] == ["sim"]:
        from ..sim.cli import main as sim_main

        return sim_main(args_list[1:])
    if args_list[:1] == ["bench"]:
        from ..bench.cli import main as bench_main

        return bench_main(args_list[1:], console=console)
    if args_list[:1] == ["monitor"]:
        from ..monitor.cli import main as monitor_main

        return monitor_main(args_list[1:], console=console)
    if args_list[:1] == ["serve"]:
        from ..network.cli import main as serve_main

        return serve_main(args_list[1:])
    if args_list[:1] == ["ros2"]:
        from ..ros2.cli import main as ros2_main

        return ros2_main(args_list[1:])
    args = build_parser().parse_args(args_list)
    result: int = run_event_loop(args.handler, args, console)
    return result


def run() -> int:
    """Console-script entry point."""
    return main()
