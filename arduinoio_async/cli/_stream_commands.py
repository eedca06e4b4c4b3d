"""``arduinoio stream``: the board's firmware-timed samples from the command line.

``arduinoio stream --analog A0 A1 --i2c 0x68:0x3B:14 --period-ms 1 --seconds 2`` starts a
stream with the analog channels and the I2C register blocks the board reads itself each
period (docs/sensors.md), prints one line every ``--every`` samples (board time, the
values, each block's bytes in hex or ``failed`` with its error) and at the end the
counts: samples, gaps, dropped, failed block reads.  ``--imu`` sets up an MPU-6050 at
0x68 (ranges +-2 g, +-250 dps) and prints its block in SI units.
"""

from __future__ import annotations

import argparse
from typing import Any

import anyio
from rich.console import Console

from .. import protocol as p
from ..board.i2c_blocks import I2CBlock
from ..board.imu import MPU6050
from ..errors import UsageError
from ._board_commands import analog_pin
from ._target import add_target_options, target_board

__all__ = ["add_commands", "i2c_block"]


def i2c_block(text: str) -> I2CBlock:
    """``ADDRESS:REGISTER:LENGTH`` (each decimal or 0x hex) as an I2CBlock."""
    try:
        address, register, length = (int(part, 0) for part in text.split(":"))
        return I2CBlock(address, register, length)
    except (ValueError, UsageError) as exc:
        raise argparse.ArgumentTypeError(
            f"{text}: an I2C block is ADDRESS:REGISTER:LENGTH, e.g. 0x68:0x3B:14 ({exc})"
        ) from None


def add_commands(sub: Any) -> None:
    """Add ``stream`` to the ``arduinoio`` command line."""
    st = sub.add_parser("stream", help="firmware-timed samples (analog, I2C blocks)")
    st.add_argument("--analog", type=analog_pin, nargs="*", default=[], help="A0-A5")
    st.add_argument("--i2c", type=i2c_block, action="append", default=[], metavar="A:R:N")
    st.add_argument("--imu", action="store_true", help="an MPU-6050 at 0x68, in SI units")
    st.add_argument("--speed", type=int, choices=[100, 400], default=400, help="I2C kHz")
    st.add_argument("--period-ms", type=float, default=10.0)
    st.add_argument("--seconds", type=float, default=2.0)
    st.add_argument("--every", type=int, default=100, help="print every Nth sample")
    st.set_defaults(handler=run_stream)
    add_target_options(st)


async def run_stream(args: argparse.Namespace, console: Console) -> int:
    """``arduinoio stream [--analog A0 ..] [--i2c A:R:N ..] [--imu] [--period-ms P]``."""
    if not args.seconds > 0 or args.every < 1:
        raise UsageError("--seconds must be positive and --every at least 1")
    blocks: list[I2CBlock] = list(args.i2c)
    async with target_board(args) as target:
        board = target.board
        imu = None
        if blocks or args.imu:
            speed = p.I2CSpeed.KHZ_400 if args.speed == 400 else p.I2CSpeed.KHZ_100
            bus = await board.i2c(speed)
            if args.imu:
                imu = MPU6050(bus)
                await imu.configure()
                blocks.insert(0, imu.block)
        count = failed = 0
        async with board.stream(analog=args.analog, i2c=blocks, period_ms=args.period_ms) as s:
            with anyio.move_on_after(args.seconds):
                async for sample in s:
                    count += 1
                    failed += sum(1 for b in sample.i2c or () if b is None)
                    if count % args.every == 1 or args.every == 1:
                        console.print(_line(sample, imu))
        console.print(
            f"samples {count}, gaps {s.gaps}, dropped {s.dropped}, failed block reads {failed}"
        )
    return 0


def _line(sample: Any, imu: MPU6050 | None) -> str:
    parts = [f"t={sample.board_time_us} us"]
    parts += [f"{pin.name}={value}" for pin, value in sample.analog.items()]
    for k, data in enumerate(sample.i2c or ()):
        if data is None:
            parts.append(f"block{k}=failed ({p.ErrorCode(sample.i2c_status[k]).name})")
        elif imu is not None and k == 0:
            r = imu.decode(data)
            accel = ",".join(f"{a:+.2f}" for a in r.accel)
            gyro = ",".join(f"{w:+.3f}" for w in r.gyro)
            parts.append(f"accel=({accel}) m/s^2 gyro=({gyro}) rad/s {r.temperature_c:.1f} C")
        else:
            parts.append(f"block{k}={data.hex()}")
    return "  ".join(parts)
