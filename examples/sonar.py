"""Two HC-SR04 sonars fired in turn by the board: distances in mm, "no echo" as such.

    python examples/sonar.py [--port P] [--seconds 2]

Front sonar: trigger D7, echo D8; rear sonar: trigger D4, echo D5 (any digital pins), on
the `sensing` firmware image (docs/firmware-profiles.md).  The board fires one sonar at a
time (so neither hears the other's ping) every 30 ms and times each echo itself; the
script reads the latest distances.  "no echo" means nothing within ~4 m, never an old
distance.  Wiring: docs/sensors.md.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D4, D5, D7, D8
from arduinoio_async.board.sonars import SonarReading
from arduinoio_async.sim import example_arguments, example_board


def shown(reading: SonarReading) -> str:
    if reading.distance_mm is not None:
        return f"{reading.distance_mm:5d} mm"
    return "no echo" if reading.no_echo else "waiting"


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()
    async with example_board(args, fixture="open", profile="sensing") as board:
        front = await board.sonar(D7, D8)
        rear = await board.sonar(D4, D5)
        await board.sonar_timing(period_ms=30, temperature_c=20.0)
        print("ready", flush=True)
        interval = 0.25
        for _ in range(round(args.seconds / interval)):
            await anyio.sleep(interval)
            f, r = await front.read(), await rear.read()
            print(f"front {shown(f)}   rear {shown(r)}", flush=True)


if __name__ == "__main__":
    anyio.run(main)
