"""Bench commands for the motor outputs: ``pwm`` (duty-cycle PWM) and ``motor`` (an H-bridge).

``arduinoio pwm D5 0.4 --freq 62.5k`` leaves D5 at 40 % on the board (the role stays
until ``arduinoio release D5`` or a reset, as ``servo`` does); ``arduinoio motor D9 D7 D8
--speed -0.5`` drives an L298N/TB6612 (EN/PWM, IN1, IN2), ``--two-pwm`` a DRV8833.
A frequency the pin's timer does not give is refused with the ones it does.
"""

from __future__ import annotations

import argparse
from typing import Any, cast

from rich.console import Console

from ..errors import UsageError
from ..protocol.pins import DigitalPin, DutyPwmPin
from ..protocol.timers import DUTY_FREQUENCIES, TIMER_OF, nearest_frequency
from ._board_commands import digital_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands", "frequency", "pick_frequency"]


def frequency(text: str) -> float:
    """``31k``, ``31.25k``, ``490``, ``20kHz`` -> Hz."""
    t = text.strip().lower().removesuffix("hz")
    scale = 1000.0 if t.endswith("k") else 1.0
    try:
        value = float(t.removesuffix("k")) * scale
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text}: a frequency such as 490, 3.9k or 31k") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text}: a frequency must be positive")
    return value


def pick_frequency(pin: DigitalPin, wanted: float | None) -> int | None:
    """The offered frequency of ``pin``'s timer within 10 % of ``wanted`` (None: default)."""
    if wanted is None or pin not in TIMER_OF:
        return None
    timer = TIMER_OF[pin]
    hz = nearest_frequency(timer, wanted)
    if max(hz / wanted, wanted / hz) > 1.1:
        offered = ", ".join(f"{f} Hz" for f in DUTY_FREQUENCIES[timer])
        raise UsageError(f"{pin.name} ({timer}) gives {offered}; not {wanted:g} Hz")
    return hz


def _speed(text: str) -> float:
    return float(text)


def add_commands(sub: Any) -> None:
    """Add ``pwm`` and ``motor`` to the ``arduinoio`` command line."""
    pwm = sub.add_parser("pwm", help="duty-cycle PWM (analogWrite) on D3, D5, D6, D9, D10")
    pwm.add_argument("pin", type=digital_pin)
    pwm.add_argument("duty", type=float, help="0.0-1.0")
    pwm.add_argument("--freq", type=frequency, help="e.g. 490, 3.9k, 31k (the pin's timer's)")
    pwm.set_defaults(handler=set_pwm)
    motor = sub.add_parser("motor", help="drive a DC motor through an H-bridge")
    motor.add_argument("pins", type=digital_pin, nargs="+", help="PWM DIR [DIR2], or IN1 IN2")
    motor.add_argument("--two-pwm", action="store_true", help="IN1/IN2 both PWM (DRV8833)")
    action = motor.add_mutually_exclusive_group(required=True)
    action.add_argument("--speed", type=_speed, help="-1.0..1.0 (negative = reverse)")
    action.add_argument("--brake", action="store_true", help="short the motor: stop fast")
    action.add_argument("--coast", action="store_true", help="open the motor: spin down")
    motor.add_argument("--freq", type=frequency)
    motor.set_defaults(handler=run_motor)
    for parser in (pwm, motor):
        add_target_options(parser)


async def set_pwm(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio pwm PIN DUTY [--freq F]``."""
    pin: DigitalPin = args.pin
    hz = pick_frequency(pin, args.freq)
    async with target_board(args) as target:
        handle = await target.board.pwm(cast(DutyPwmPin, pin), args.duty, frequency_hz=hz)
        console.print(
            f"{pin.name}: {handle.duty * 100:.1f} % at {handle.frequency_hz} Hz "
            f"({handle.timer}, {handle.steps} steps)"
        )
    return 0


async def run_motor(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio motor PWM DIR [DIR2] --speed S | --brake | --coast``."""
    pins: list[DigitalPin] = args.pins
    if (args.two_pwm and len(pins) != 2) or not 2 <= len(pins) <= 3:
        raise UsageError("motor takes PWM DIR [DIR2], or IN1 IN2 with --two-pwm")
    hz = pick_frequency(pins[0], args.freq)
    async with target_board(args) as target:
        board = target.board
        if args.two_pwm:
            in1, in2 = (cast(DutyPwmPin, q) for q in pins)
            motor = await board.motor_2pwm(in1, in2, frequency_hz=hz)
        else:
            second = pins[2] if len(pins) == 3 else None
            motor = await board.motor(cast(DutyPwmPin, pins[0]), pins[1], second, frequency_hz=hz)
        if args.brake:
            await motor.brake()
        elif args.coast:
            await motor.coast()
        else:
            await motor.set_speed(args.speed)
        console.print(f"motor {' '.join(q.name for q in pins)}: {motor.state} {motor.speed:+.2f}")
    return 0
