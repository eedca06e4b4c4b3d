"""Bench command for issue 26's steppers: ``arduinoio stepper STEP DIR ...``.

``arduinoio stepper D2 D3 --by 2000 --speed 1500 --accel 3000`` moves a stepper on an
A4988/DRV8825/TMC2209 (STEP, DIR) and prints where it stopped and why; ``--run 800
--seconds 2`` runs it at a speed, then decelerates; ``--home --limit D4`` runs toward the
switch on D4 (to ground) until it closes.  Each run configures the stepper afresh, so
positions count from where the motor stands (``--to`` and ``--by`` are the same then).
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from ..board.steppers import Stepper
from ..errors import UsageError
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands"]


def add_commands(sub: Any) -> None:
    """Add ``stepper`` to the ``arduinoio`` command line."""
    cmd = sub.add_parser("stepper", help="move a step/dir stepper (A4988, DRV8825, TMC2209)")
    cmd.add_argument("step", type=digital_pin, help="the driver's STEP pin")
    cmd.add_argument("dir", type=digital_pin, help="the driver's DIR pin")
    action = cmd.add_mutually_exclusive_group(required=True)
    action.add_argument("--to", type=int, help="move to this position (steps)")
    action.add_argument("--by", type=int, help="move by this many steps (signed)")
    action.add_argument("--run", type=int, help="run at this speed (steps/s, signed)")
    action.add_argument("--home", action="store_true", help="run to the --limit switch")
    cmd.add_argument("--speed", type=int, default=1000, help="top speed, steps/s (1000)")
    cmd.add_argument("--accel", type=int, default=2000, help="acceleration, steps/s^2 (2000)")
    cmd.add_argument("--seconds", type=float, default=1.0, help="how long --run runs (1)")
    cmd.add_argument("--limit", type=digital_pin, help="limit switch (to ground) on this side")
    cmd.add_argument("--positive", action="store_true", help="--limit/--home: positive side")
    cmd.add_argument("--timeout", type=float, default=60.0, help="longest wait, s (60)")
    cmd.set_defaults(handler=run_stepper)
    add_target_options(cmd)


async def run_stepper(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio stepper STEP DIR --to N | --by N | --run S | --home``."""
    if args.home and args.limit is None:
        raise UsageError("--home needs the switch: --limit PIN")
    async with target_board(args) as target:
        stepper: Stepper = await target.board.stepper(
            step=args.step, dir=args.dir, max_speed=args.speed, acceleration=args.accel
        )
        try:
            if args.limit is not None:
                await stepper.limit(args.limit, positive=args.positive)
            if args.home:
                ran = await stepper.home(args.speed, positive=args.positive, timeout=args.timeout)
                console.print(f"stepper {args.step.name}: homed after {ran} steps, position 0")
                return 0
            if args.run is not None:
                await stepper.run(args.run)
                await anyio.sleep(args.seconds)
                await stepper.stop()
            elif args.to is not None:
                await stepper.move_to(args.to)
            else:
                await stepper.move_by(args.by)
            state = await stepper.wait(timeout=args.timeout)
            why = stepper.last_done.reason.name.lower() if stepper.last_done else "at rest"
            console.print(f"stepper {args.step.name}: position {state.position} ({why})")
        finally:
            await stepper.release()
    return 0
