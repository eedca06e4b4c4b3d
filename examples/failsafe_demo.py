"""The failsafe: a stalled controller lets the board put its outputs in safe states.

    python examples/failsafe_demo.py [--port P] [--timeout-ms 100]

The board's link watchdog is fed by every request, and the library sends a cheap
heartbeat while the process is healthy.  Here the program blocks its own event loop on
purpose (as a hung computation would): the board stops hearing from it, drives the motor
servo to its safe width and the LED off, reports the trip, and refuses output commands
until the program re-arms it.
"""

from __future__ import annotations

import time

import anyio

from arduinoio_async import D9, D13, FailsafeTrippedError
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--timeout-ms", type=int, default=100)
    args = parser.parse_args()
    async with example_board(args) as board:
        motor = await board.servo(D9, pulse_us=1800)
        led = await board.digital_output(D13, initial=True)
        fired = anyio.Event()
        board.on_failsafe(lambda b: fired.set())
        await board.arm_failsafe(args.timeout_ms, {motor: 1000, led: False})
        print(f"armed: {args.timeout_ms} ms without a request puts D9 at 1000 us and D13 low")

        # A stalled event loop, on purpose: no heartbeat goes out while it blocks.
        time.sleep(3 * args.timeout_ms / 1000)  # noqa: ASYNC251
        with anyio.fail_after(2):
            await fired.wait()
        print("failsafe fired: outputs are in their safe states")
        try:
            await led.write(True)
        except FailsafeTrippedError as exc:
            print("refused while tripped:", exc)

        await board.rearm_failsafe()  # arm again and put every output back as it was
        print(f"re-armed: D13 reads {await led.read()}, D9 at {motor.pulse_us} us")
        await board.disarm_failsafe()


if __name__ == "__main__":
    anyio.run(main)
