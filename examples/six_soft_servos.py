"""Drive six servos from the software PWM pins D2-D7, each at its own width.

    python examples/six_soft_servos.py [--port P]

Software PWM gives D2-D7 the same 50 Hz servo signal as the hardware pins D9/D10, in
steps of ``SOFT_PWM_STEP_US`` (see docs/protocol.md), so a six-legged robot's joints need
no extra servo controller.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D2, D3, D4, D5, D6, D7
from arduinoio_async import protocol as p
from arduinoio_async.protocol.pins import SoftPwmPin
from arduinoio_async.sim import example_arguments, example_board

PINS: tuple[SoftPwmPin, ...] = (D2, D3, D4, D5, D6, D7)


async def main() -> None:
    parser = example_arguments(__doc__)
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        step = (p.SERVO_DEFAULT_MAX_US - p.SERVO_DEFAULT_MIN_US) // (len(PINS) - 1)
        joints = []
        for n, pin in enumerate(PINS):
            width = p.SERVO_DEFAULT_MIN_US + n * step
            width -= width % p.SOFT_PWM_STEP_US
            joints.append(await board.soft_pwm(pin, pulse_us=width))
        for joint in joints:
            print(f"{joint.pin.name}: {joint.pulse_us} us")
        await anyio.sleep(0.1)  # let a few periods go out before the program ends


if __name__ == "__main__":
    anyio.run(main)
