"""Drive a DC motor through an L298N (or TB6612) H-bridge: ramp, reverse, brake, cruise.

    python examples/dc_motor.py [--port P] [--cruise 0.6]

Wiring (docs/motors.md): ENA -> D9 (Timer1 duty PWM at 20 kHz, above hearing), IN1 -> D7,
IN2 -> D8, the driver's GND to the Uno's GND, the motor supply on the driver's VS.  The
failsafe is armed with the motor: if this program dies or stalls, the board stops it
within 200 ms.  The program leaves the motor cruising, and the board keeps it so until
the failsafe fires, a reset or ``arduinoio release D9``.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D7, D8, D9
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--cruise", type=float, default=0.6, help="final speed, -1..1")
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        motor = await board.motor(D9, D7, D8, frequency_hz=20000)
        await board.arm_failsafe(200, {motor: 0})
        for step in range(11):  # ramp up forward, 0 to 100 % in 10 % steps
            await motor.set_speed(step / 10)
            await anyio.sleep(0.02)
        await motor.brake()
        print("braked", flush=True)
        for step in range(6):  # then reverse up to half speed
            await motor.set_speed(-step / 10)
            await anyio.sleep(0.02)
        await motor.coast()
        await motor.set_speed(args.cruise)
        await board.disarm_failsafe()  # the program ends: leave the motor cruising
        pwm = motor.speed_pins[0]
        print(
            f"motor at {motor.speed:+.2f}: {pwm.pin.name} {pwm.duty * 100:.1f} % at "
            f"{pwm.frequency_hz} Hz"
        )


if __name__ == "__main__":
    anyio.run(main)
