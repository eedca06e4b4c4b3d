"""Bench checks and maintenance: read, write, servo, analog, i2c, release, reset, failsafe,
set-id.

Pin roles live on the board until released or reset, so each command that configures a
pin says how to free it when the board refuses (see :class:`~arduinoio_async.errors.
BoardError`), and ``release``/``reset`` do it from the command line.
"""

from __future__ import annotations

import argparse
from typing import Any

from rich.console import Console

from .. import protocol as p
from ..errors import ArduinoIOError, UsageError
from ..protocol.pins import UNO_ANALOG, AnalogPin, DigitalPin, Function, require
from ._roles import pin_roles
from ._target import add_target_options, board_id, target_board


def digital_pin(text: str) -> DigitalPin:
    try:
        return DigitalPin[text.upper()]
    except KeyError:
        raise argparse.ArgumentTypeError(f"{text}: digital pins are D2-D13") from None


def analog_pin(text: str) -> AnalogPin:
    try:
        return AnalogPin[text.upper()]
    except KeyError:
        raise argparse.ArgumentTypeError(f"{text}: analog pins are A0-A5") from None


def byte_value(text: str) -> int:
    value = int(text, 0)
    if not 0 <= value <= 0xFF:
        raise argparse.ArgumentTypeError(f"{text} is not a byte")
    return value


def add_commands(sub: Any) -> None:
    read = sub.add_parser(
        "read",
        help="read a digital input (level and edges), or the level an output drives",
    )
    read.add_argument("pin", type=digital_pin)
    read.add_argument("--pull-up", action="store_true")
    read.set_defaults(handler=read_pin)
    write = sub.add_parser("write", help="set a digital output")
    write.add_argument("pin", type=digital_pin)
    write.add_argument("value", type=int, choices=[0, 1])
    write.set_defaults(handler=write_pin)
    servo = sub.add_parser("servo", help="servo pulse in us (D9/D10 hardware, D2-D7 software)")
    servo.add_argument("pin", type=digital_pin)
    servo.add_argument("pulse_us", type=int)
    servo.add_argument("--min-us", type=int, default=p.SERVO_DEFAULT_MIN_US, help="limit (500+)")
    servo.add_argument("--max-us", type=int, default=p.SERVO_DEFAULT_MAX_US, help="limit (-2500)")
    servo.set_defaults(handler=set_servo)
    analog = sub.add_parser("analog", help="read one analog input or all six")
    analog.add_argument("pin", type=analog_pin, nargs="?")
    analog.set_defaults(handler=read_analog)
    i2c = sub.add_parser("i2c", help="I2C register read or write, or scan the bus")
    i2c.add_argument("action", choices=["read", "write", "scan"])
    i2c.add_argument("address", type=byte_value, nargs="?")
    i2c.add_argument("register", type=byte_value, nargs="?")
    i2c.add_argument("values", type=byte_value, nargs="*", help="read: length; write: bytes")
    i2c.add_argument("--speed", type=int, choices=[100, 400], default=100)
    i2c.set_defaults(handler=i2c_transfer)
    release = sub.add_parser(
        "release", help="free digital pins from their roles (they become plain inputs)"
    )
    release.add_argument("pins", type=digital_pin, nargs="+", metavar="PIN")
    release.set_defaults(handler=release_pins)
    reset = sub.add_parser(
        "reset",
        help="reset the board: every pin released, stream stopped, failsafe cleared",
    )
    reset.set_defaults(handler=reset_board)
    failsafe = sub.add_parser(
        "failsafe", help="show the failsafe state; --clear disarms it (also when tripped)"
    )
    failsafe.add_argument(
        "--clear",
        action="store_true",
        help="disarm the failsafe; outputs keep their safe states until commanded",
    )
    failsafe.set_defaults(handler=failsafe_command)
    set_id = sub.add_parser("set-id", help="write a board ID to EEPROM and verify after reset")
    set_id.add_argument("new_id", type=board_id)
    set_id.add_argument(
        "--force", action="store_true", help="also when another board already answers with it"
    )
    for parser in (read, write, servo, analog, i2c, release, reset, failsafe, set_id):
        add_target_options(parser)
    set_id.set_defaults(handler=set_board_id)


async def read_pin(args: argparse.Namespace, console: Console) -> int:
    """An input's level and edges; an output's driven level, leaving it an output.

    Roles outlive the command that gave them, so a pin an earlier ``write`` made an
    output is still one: the board says so (``ReadPinRoles``) and reads its level as it
    is, instead of this command turning it into an input.
    """
    async with target_board(args) as target:
        board = target.board
        if (await pin_roles(board)).get(args.pin.name) == "digital output":
            if args.pull_up:
                raise UsageError(
                    f"{args.pin.name} is a digital output on the board: --pull-up is for "
                    f"inputs (free it first with `arduinoio release {args.pin.name}`)"
                )
            reply = await board.request(p.GpioRead(args.pin))
            console.print(f"{args.pin.name}: level {int(reply.level)} (digital output)")
            return 0
        state = await (await board.digital_input(args.pin, pull_up=args.pull_up)).read()
        console.print(
            f"{args.pin.name}: level {int(state.level)} rose {int(state.rose)} "
            f"fell {int(state.fell)}"
        )
    return 0


async def write_pin(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        await board.gpio(args.pin).write(bool(args.value))
        console.print(f"{args.pin.name} = {args.value}")
    return 0


async def set_servo(args: argparse.Namespace, console: Console) -> int:
    pin = args.pin
    async with target_board(args) as target:
        board = target.board
        limits = {"min_us": args.min_us, "max_us": args.max_us}
        if pin in (DigitalPin.D9, DigitalPin.D10):
            await board.servo(pin, pulse_us=args.pulse_us, **limits)
        else:
            require(pin, Function.SOFT_PWM)
            await board.soft_pwm(pin, pulse_us=args.pulse_us, **limits)
        console.print(f"{pin.name}: {args.pulse_us} us every 20 ms")
    return 0


async def read_analog(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        if args.pin is not None:
            value = await board.analog(args.pin).read()
            console.print(f"{args.pin.name}: {value} ({value * 5 / 1024:.3f} V)")
        else:
            for pin, value in zip(UNO_ANALOG, await board.read_analog_all(), strict=True):
                console.print(f"{pin.name}: {value} ({value * 5 / 1024:.3f} V)")
    return 0


async def i2c_transfer(args: argparse.Namespace, console: Console) -> int:
    speed = p.I2CSpeed.KHZ_400 if args.speed == 400 else p.I2CSpeed.KHZ_100
    async with target_board(args) as target:
        board = target.board
        bus = await board.i2c(speed)
        if args.action == "scan":
            if args.address is not None:
                raise UsageError("i2c scan takes no address (it tries 0x08-0x77)")
            found = await bus.scan()
            console.print(" ".join(f"0x{a:02X}" for a in found) or "no device answered")
            return 0
        if args.address is None or args.register is None or not args.values:
            raise UsageError(f"i2c {args.action} takes an address, a register and values")
        if args.action == "read":
            if len(args.values) != 1:
                raise UsageError("i2c read takes one length")
            data = await bus.read(args.address, args.register, args.values[0])
            console.print(data.hex(" "))
        else:
            await bus.write(args.address, args.register, bytes(args.values))
            console.print(f"wrote {len(args.values)} bytes")
    return 0


async def set_board_id(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        old = board.board_id
        if not args.force and args.new_id != old:
            holders = await target.boards_elsewhere()
            if args.new_id in holders:
                raise UsageError(
                    f"board ID 0x{args.new_id:04X} is already used by the board on "
                    f"{holders[args.new_id]}: two boards with one ID cannot be told apart "
                    "(use --force to write it anyway)"
                )
        await board.write_id(args.new_id)
        await board.reset()
        read_back = await board.read_id()
        if read_back != args.new_id:
            raise ArduinoIOError(
                f"board answered ID 0x{read_back:04X} after reset, not 0x{args.new_id:04X}"
            )
        console.print(f"board ID 0x{old:04X} -> 0x{read_back:04X} (verified after reset)")
    return 0


async def release_pins(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        for pin in args.pins:
            await target.board.release(pin)
    console.print(f"released {', '.join(pin.name for pin in args.pins)}", highlight=False)
    return 0


async def reset_board(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        await board.reset()
        console.print(
            f"board 0x{board.board_id:04X} on {board.port} reset: pins released, "
            "stream stopped, failsafe off",
            highlight=False,
        )
    return 0


async def failsafe_command(args: argparse.Namespace, console: Console) -> int:
    async with target_board(args) as target:
        board = target.board
        flags = (await board.status()).flags
        if flags & p.StatusFlags.FAILSAFE_TRIPPED:
            state = "tripped"
        elif flags & p.StatusFlags.FAILSAFE_ARMED:
            state = "armed"
        else:
            state = "off"
        if args.clear:
            await board.disarm_failsafe()
            console.print(f"failsafe was {state}; now off", highlight=False)
        else:
            hint = " (clear it with --clear)" if state != "off" else ""
            console.print(f"failsafe {state}{hint}", highlight=False)
    return 0
