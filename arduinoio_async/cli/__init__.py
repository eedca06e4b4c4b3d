"""The ``arduinoio`` command: bench checks, discovery, IDs, flashing, simulator, benchmark.

Every sub-command is an ``async def`` taking parsed arguments; :func:`main` takes
``argv`` and returns the exit code, so tests call it directly.  Errors of the library are
printed as one line and exit with 1; a missing tool (avrdude, simulator) exits with 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from rich.console import Console

from ..errors import ArduinoIOError
from ..transport import run as run_event_loop  # uvloop when installed
from . import _board_commands, _discovery, _flash, _motor_commands

__all__ = ["main", "run"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arduinoio", description="Arduino Unos as robot I/O boards (arduinoio_async)."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _discovery.add_commands(sub)
    _board_commands.add_commands(sub)
    _motor_commands.add_commands(sub)
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
    return parser


def main(argv: Sequence[str] | None = None, *, console: Console | None = None) -> int:
    """Run the command line ``argv``; returns the process exit code."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    console = console or Console()
    errors = Console(stderr=True)
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
    parser = build_parser()
    args = parser.parse_args(args_list)
    try:
        result: int = run_event_loop(args.handler, args, console)
    except ArduinoIOError as exc:
        errors.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 1
    except _flash.ToolMissing as exc:
        errors.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 2
    except KeyboardInterrupt:
        return 130
    return result


def run() -> int:
    """Console-script entry point."""
    return main()
