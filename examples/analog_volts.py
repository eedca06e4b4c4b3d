"""Read the six analog inputs A0-A5 and print them in volts.

    python examples/analog_volts.py [--port P] [--samples 3]

``read_volts()`` scales the 10-bit reading by the 5 V reference (AVCC on the Uno);
``read_analog_all()`` takes all six channels in one request.
"""

from __future__ import annotations

import anyio

from arduinoio_async import A0, A1, A2, A3, A4, A5
from arduinoio_async.sim import example_arguments, example_board

CHANNELS = (A0, A1, A2, A3, A4, A5)


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--samples", type=int, default=3)
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        for _ in range(args.samples):
            volts = [await board.analog(pin).read_volts() for pin in CHANNELS]
            print(
                "  ".join(f"{pin.name} {v:.2f} V" for pin, v in zip(CHANNELS, volts, strict=True))
            )
            await anyio.sleep(0.1)
        raw = await board.read_analog_all()  # one request, all six channels
        print("raw:", " ".join(str(value) for value in raw))


if __name__ == "__main__":
    anyio.run(main)
