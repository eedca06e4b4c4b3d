"""``arduinoio sonar TRIGGER ECHO``: read an HC-SR04 style sonar from the command line.

``arduinoio sonar D7 D8 --seconds 5`` sets up a sonar on the board (which fires it every
``--period-ms``) and prints its distance, or "no echo", every ``--interval`` seconds, then
releases both pins.  Wiring: docs/sensors.md.
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from ..errors import UsageError
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands"]


def add_commands(sub: Any) -> None:
    """Add ``sonar`` to the ``arduinoio`` command line."""
    cmd = sub.add_parser("sonar", help="read an HC-SR04 sonar (trigger and echo on any two pins)")
    cmd.add_argument("trigger", type=digital_pin, help="the trigger pin (D2-D13)")
    cmd.add_argument("echo", type=digital_pin, help="the echo pin (D2-D13)")
    cmd.add_argument("--period-ms", type=int, default=60, help="ms between firings (1-65535)")
    cmd.add_argument("--temperature", type=float, default=None, help="air temperature, C")
    cmd.add_argument("--seconds", type=float, default=5.0, help="how long to watch")
    cmd.add_argument("--interval", type=float, default=0.5, help="seconds between lines")
    cmd.set_defaults(handler=watch_sonar)
    add_target_options(cmd)


async def watch_sonar(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio sonar TRIGGER ECHO [--period-ms P] [--seconds S] [--interval I]``."""
    if not args.interval > 0 or not args.seconds >= 0:
        raise UsageError("--interval must be positive and --seconds not negative")
    async with target_board(args) as target:
        board = target.board
        sonar = await board.sonar(args.trigger, args.echo)
        try:
            await board.sonar_timing(period_ms=args.period_ms, temperature_c=args.temperature)
            console.print(f"sonar {args.trigger.name}/{args.echo.name}: every {args.period_ms} ms")
            for _ in range(max(1, round(args.seconds / args.interval))):
                await anyio.sleep(args.interval)
                now = await sonar.read()
                if now.distance_mm is not None:
                    what = f"{now.distance_mm} mm (echo {now.echo_us} us)"
                else:
                    what = "no echo" if now.no_echo else "no reading yet"
                console.print(f"{what}  age {now.age_ms} ms  readings {now.readings}")
        finally:
            with anyio.CancelScope(shield=True):
                await sonar.release()
    return 0
