"""The paper's robot (Sec. V) on one firmware: an actuator board and a sensor board.

    python examples/paper_robot.py --port ACTUATORS_PORT --port SENSORS_PORT [--seconds 3]
    python examples/paper_robot.py --virtual       # two virtual Unos

The paper's robot needed a second, separate firmware for its real-time sensors; here both
boards run this project's firmware, found by board ID under one BoardManager:

* actuator board (ID 1, the ``standard`` image): steering servo on D9, the ESC on D10 (an
  ESC takes servo pulses: 1,500 us is stop), the link failsafe armed: if the host stops,
  the board itself puts both at 1,500 us within 200 ms;
* sensor board (ID 2, the ``sensing`` image): wheel encoders on D2/D3 and D4/D5, an
  MPU-6050 on A4/A5 and an HC-SR04 on D7 (trigger) / D8 (echo), all in one stream the
  board times every 10 ms (encoder counts, the sonar's latest distance, the IMU's 14 bytes).

The control loop, once per sample: throttle from the sonar (stop nearer than 300 mm, full
at 1,300 mm and beyond: ESC 1,500-1,800 us), steering from the wheels' count difference
(1 us per count, 1,000-2,000 us: a heading hold).  At the end the host stops feeding on
purpose (a hung event loop) and the actuator board's failsafe takes over.  Wiring:
docs/sensors.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio

from arduinoio_async import D2, D3, D4, D5, D7, D8, D9, D10, MPU6050, BoardManager, I2CSpeed
from arduinoio_async.sim import VirtualUno

ACTUATORS, SENSORS = 0x0001, 0x0002
FAILSAFE_MS = 200


def throttle_us(distance_mm: int | None) -> int:
    """ESC width for the obstacle ahead: 1,500 (stop) nearer than 300 mm or unknown."""
    if distance_mm is None or distance_mm < 300:
        return 1500
    return 1500 + round(300 * min(1.0, (distance_mm - 300) / 1000))


def steering_us(left: int, right: int) -> int:
    """Steer against the wheels' count difference (1 us a count, within 1,000-2,000 us)."""
    return max(1000, min(2000, 1500 + (left - right)))


@asynccontextmanager
async def robot_ports(args: argparse.Namespace) -> AsyncIterator[list[str]]:
    """The ports given, or two virtual Unos with the robot's IDs and images."""
    if not args.virtual:
        yield list(args.port)
        return
    async with (
        VirtualUno(board_id=ACTUATORS) as actuators,
        VirtualUno(board_id=SENSORS, profile="sensing", fixture="open") as sensors,
    ):
        await sensors.sonar("D7", "D8", distance_mm=800)
        print("(two virtual Unos)", file=sys.stderr)
        yield [actuators.port, sensors.port]


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--port", action="append", default=[], help="a board's port")
    parser.add_argument("--virtual", action="store_true", help="run against two virtual Unos")
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    async with (
        robot_ports(args) as ports,
        BoardManager(ports=ports, usb=not ports, env=not ports, rescan_interval=None) as boards,
    ):
        actuators, sensors = await boards.get(ACTUATORS), await boards.get(SENSORS)
        steering = await actuators.servo(D9, pulse_us=1500)
        esc = await actuators.servo(D10, pulse_us=1500)
        tripped = anyio.Event()
        actuators.on_failsafe(lambda board: tripped.set())
        await actuators.arm_failsafe(FAILSAFE_MS, {steering: 1500, esc: 1500})

        await sensors.encoder(D2, D3)
        await sensors.encoder(D4, D5)
        await sensors.sonar(D7, D8)
        await sensors.sonar_timing(period_ms=30)
        imu = MPU6050(await sensors.i2c(I2CSpeed.KHZ_400))
        await imu.configure(accel_g=4, gyro_dps=500, dlpf=3)
        print("ready", flush=True)

        steer = throttle = 1500
        line = ""
        stream = sensors.stream(encoders=True, sonars=True, i2c=[imu.block], period_ms=10)
        with anyio.move_on_after(args.seconds):
            async with stream as samples:
                async for sample in samples:
                    assert sample.encoders and sample.sonars and sample.i2c is not None
                    left, right = sample.encoders[0], sample.encoders[1]
                    distance = sample.sonars[0].distance_mm
                    steer, throttle = steering_us(left, right), throttle_us(distance)
                    await steering.set_pulse(steer)
                    await esc.set_pulse(throttle)
                    if sample.i2c[0] is not None:
                        motion = imu.decode(sample.i2c[0])
                        line = (
                            f"encoders left {left} right {right}  sonar {distance} mm  "
                            f"accel z {motion.accel[2]:+.2f} m/s^2  "
                            f"gyro z {motion.gyro[2]:+.3f} rad/s  "
                            f"steering {steer} us  ESC {throttle} us"
                        )
                    if sample.sequence % 50 == 0:
                        print(line, flush=True)
        print(f"last: {line}", flush=True)
        print("host stops", flush=True)
        time.sleep(3 * FAILSAFE_MS / 1000)  # noqa: ASYNC251 (a hung host, on purpose)
        with anyio.fail_after(2):
            await tripped.wait()
        print("failsafe tripped: steering and ESC at 1500 us, set by the actuator board")


if __name__ == "__main__":
    anyio.run(main)
