"""An RC receiver's two channels: steering -1..1 and throttle 0..1, timed by the board.

    python examples/rc_receiver.py [--port P] [--seconds 2]

Steering channel on D4, throttle on D7 (any digital pins), on the `sensing` firmware image
(docs/firmware-profiles.md).  The board times every high pulse with its microsecond
clock; a channel with no pulse for 100 ms is *lost* and reads as None here, never as its
last width: a robot's RC override stops steering by radio then (its failsafe covers a dead
host).  Wiring and end points: docs/sensors.md.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D4, D7
from arduinoio_async.sim import example_arguments, example_board


def shown(value: float | None, sign: bool) -> str:
    if value is None:
        return "lost"
    return f"{value:+.2f}" if sign else f"{value:.2f}"


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()
    async with example_board(args, fixture="open", profile="sensing") as board:
        steering = await board.pulse_input(D4, timeout_ms=100)
        throttle = await board.pulse_input(D7, timeout_ms=100)
        print("ready: switch the transmitter on", flush=True)
        interval = 0.25
        for _ in range(round(args.seconds / interval)):
            await anyio.sleep(interval)
            s, t = await steering.position(), await throttle.throttle()
            print(f"steering {shown(s, True)}   throttle {shown(t, False)}", flush=True)
        state = await steering.read()
        print(f"last steering pulse: {state.width_us} us, {state.age_ms} ms ago")


if __name__ == "__main__":
    anyio.run(main)
