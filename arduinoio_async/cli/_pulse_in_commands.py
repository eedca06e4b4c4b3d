"""``arduinoio rc PIN``: read or watch an RC receiver channel from the command line.

``arduinoio rc D7`` sets up a pulse-width input on the board, waits up to its timeout for
the first pulse, prints the width (and the stick position and throttle by the default end
points), then releases the pin; ``--seconds 5`` keeps printing every ``--interval``
seconds.  A lost signal is said in words, with the last width and its age.  Wiring:
docs/sensors.md.
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from ..board.pulse_inputs import PulseInput, PulseState, scale_position, scale_throttle
from ..errors import UsageError
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands"]

#: Seconds between two reads while waiting for the first pulse after set-up.
FIRST_PULSE_POLL = 0.01


def add_commands(sub: Any) -> None:
    """Add ``rc`` (alias ``pulse-in``) to the ``arduinoio`` command line."""
    rc = sub.add_parser(
        "rc",
        aliases=["pulse-in"],
        help="read or watch an RC receiver channel (pulse width on any digital pin)",
    )
    rc.add_argument("pin", type=digital_pin, help="the channel's signal pin (D2-D13)")
    rc.add_argument(
        "--timeout-ms", type=int, default=100, help="no pulse this long: signal lost (1-65535)"
    )
    rc.add_argument("--seconds", type=float, default=0.0, help="watch this long (0: read once)")
    rc.add_argument("--interval", type=float, default=0.5, help="seconds between lines")
    rc.set_defaults(handler=pulse_in)
    add_target_options(rc)


def describe(rc: PulseInput, state: PulseState) -> str:
    """One line: the width and stick values, or the lost signal in words."""
    if state.lost:
        if not state.width_us:
            return f"{rc.pin.name}: signal lost (no pulse yet)"
        return f"{rc.pin.name}: signal lost (last width {state.width_us} us, {state.age_ms} ms ago)"
    position = scale_position(state.width_us, rc.low_us, rc.centre_us, rc.high_us)
    throttle = scale_throttle(state.width_us, rc.low_us, rc.high_us)
    return (
        f"{rc.pin.name}: width {state.width_us} us  position {position:+.2f}  "
        f"throttle {throttle:.2f}"
    )


async def first_state(rc: PulseInput) -> PulseState:
    """The state once the first pulse came, or the lost state after the timeout."""
    with anyio.move_on_after(rc.timeout_ms / 1000 + 0.1):
        while True:
            state = await rc.read()
            if not state.lost:
                return state
            await anyio.sleep(FIRST_PULSE_POLL)
    return await rc.read()


async def pulse_in(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio rc PIN [--timeout-ms T] [--seconds S] [--interval I]``."""
    if not args.interval > 0 or not args.seconds >= 0:
        raise UsageError("--interval must be positive and --seconds not negative")
    async with target_board(args) as target:
        rc = await target.board.pulse_input(args.pin, timeout_ms=args.timeout_ms)
        try:
            console.print(describe(rc, await first_state(rc)))
            for _ in range(round(args.seconds / args.interval)):
                await anyio.sleep(args.interval)
                console.print(describe(rc, await rc.read()))
        finally:
            with anyio.CancelScope(shield=True):
                await rc.release()
    return 0
