"""Home a stepper against its limit switch, then move it to positions (A4988 / DRV8825).

    python examples/stepper_homing.py [--port P] [--speed 1500]

Wiring (docs/motors.md, "Steppers"): the driver's STEP -> D2, DIR -> D3, a limit switch
from D4 to GND at the negative end of the axis.  The board runs the moves and watches the
switch itself: the stepper stops before its next step once the switch closes, however
busy the host is.  Homing runs toward the switch, calls that spot 0, then the program
moves to a few positions and prints where the board says the stepper stands.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D2, D3, D4
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--speed", type=int, default=1500, help="homing speed, steps/s")
    parser.add_argument("--to", type=int, nargs="*", default=[2000, 500], help="positions")
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        stepper = await board.stepper(step=D2, dir=D3, max_speed=4000, acceleration=20000)
        await stepper.limit(D4)  # negative side, to ground
        ran = await stepper.home(args.speed, timeout=60)
        print(f"homed after {ran} steps: position 0", flush=True)
        for target in args.to:
            state = await stepper.move_to_and_wait(target, timeout=60)
            print(f"at {state.position}", flush=True)
        await stepper.release()


if __name__ == "__main__":
    anyio.run(main)
