"""Sweep a hobby servo on D9 from 0 to 180 degrees and back, then centre it.

    python examples/servo_sweep.py [--port P] [--step 15]

D9 and D10 have hardware servo PWM (Timer1): 50 Hz, 1000-2000 us at 1 us resolution.
``set_angle`` maps 0-180 degrees onto that range (pass min_us/max_us for other servos).
"""

from __future__ import annotations

import anyio

from arduinoio_async import D9
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--step", type=int, default=15, help="degrees per step")
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        servo = await board.servo(D9, pulse_us=1500)
        angles = [*range(0, 181, args.step), *range(180, -1, -args.step)]
        for angle in angles:
            await servo.set_angle(angle)
            await anyio.sleep(0.02)  # one servo period per step
        await servo.set_angle(90)
        print(f"swept {len(angles)} steps; servo centred at {servo.pulse_us} us")


if __name__ == "__main__":
    anyio.run(main)
