"""Blink the LED on D13 and read it back through the jumper to D12.

    python examples/blink.py [--port /dev/ttyACM0] [--times 5]

On the paper's test circuit (the virtual Uno's loopback fixture) D13 is jumpered to D12,
so every level the program writes is also read back through a second pin.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D12, D13
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--times", type=int, default=5)
    args = parser.parse_args()
    async with example_board(args) as board:
        led = await board.digital_output(D13)
        sense = await board.digital_input(D12)
        for n in range(args.times):
            for level in (True, False):
                await led.write(level)
                seen = (await sense.read()).level
                print(f"blink {n + 1}: D13 {'on ' if level else 'off'} -> D12 reads {seen}")
                await anyio.sleep(0.1)
        print(f"blinked {args.times} times")


if __name__ == "__main__":
    anyio.run(main)
