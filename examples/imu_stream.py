"""An MPU-6050 streamed by the board: acceleration and rotation at 1 kHz with 4 analog
channels, every sample timed by the board.

    python examples/imu_stream.py [--port P] [--baud 1000000] [--seconds 1]

Wiring (docs/sensors.md): the IMU's SDA on A4, SCL on A5, VCC 5 V (GY-521 board), GND,
AD0 to GND (address 0x68).  Needs the ``sensing`` firmware image
(``arduinoio flash --profile sensing``); without ``--port`` a virtual Uno runs it, with
its model of an MPU-6050.  The board reads the IMU's 14 data bytes itself each period
(an interrupt-driven I2C read that overlaps the period), so the host never asks; a
period whose read failed shows as a gap in ``ok``, never as a stalled stream.
"""

from __future__ import annotations

import anyio

from arduinoio_async import A0, A1, A2, A3, MPU6050, I2CSpeed
from arduinoio_async.board.i2c_blocks import block_errors
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.set_defaults(baud=1_000_000)
    args = parser.parse_args()
    async with example_board(args, fixture="open", profile="sensing") as board:
        imu = MPU6050(await board.i2c(I2CSpeed.KHZ_400))
        await imu.configure(accel_g=4, gyro_dps=500, dlpf=3)
        print(f"one-shot: {await imu.read()}")
        ok = failed = 0
        total = round(args.seconds * 1000)
        async with board.stream(analog=[A0, A1, A2, A3], i2c=[imu.block], period_ms=1) as samples:
            async for sample in samples:
                assert sample.i2c is not None
                if sample.i2c[0] is None:
                    failed += 1
                else:
                    ok += 1
                    if ok % 250 == 1:
                        r = imu.decode(sample.i2c[0])
                        accel = " ".join(f"{a:+6.2f}" for a in r.accel)
                        gyro = " ".join(f"{w:+6.3f}" for w in r.gyro)
                        print(
                            f"t={sample.board_time_us / 1e6:9.4f} s  accel {accel} m/s^2  "
                            f"gyro {gyro} rad/s  {r.temperature_c:.1f} C"
                        )
                if ok + failed >= total:
                    break
        errors = await block_errors(board, 0)
        print(
            f"samples: ok {ok}, failed reads {failed} (board counted {errors}), gaps {samples.gaps}"
        )


if __name__ == "__main__":
    anyio.run(main)
