"""Two wheel encoders on the counter pins D2 (INT0) and D3 (INT1): counts and speed.

    python examples/wheel_encoder.py [--port P] [--seconds 2] [--ticks-per-rev 20]

The board counts every edge in an interrupt, so no pulse is lost between reads however
slowly the host polls; ``reset()`` reads and zeroes in one request (no pulse can fall
between a read and a reset).
"""

from __future__ import annotations

import anyio

from arduinoio_async import D2, D3
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--ticks-per-rev", type=int, default=20)
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        left, right = await board.counter(D2), await board.counter(D3)
        totals = [0, 0]
        interval = 0.25
        print("ready: turn the wheels", flush=True)
        for _ in range(round(args.seconds / interval)):
            await anyio.sleep(interval)
            ticks = [await left.reset(), await right.reset()]
            totals = [total + t for total, t in zip(totals, ticks, strict=True)]
            rpm = [t / args.ticks_per_rev / interval * 60 for t in ticks]
            print(f"left {rpm[0]:6.1f} rpm   right {rpm[1]:6.1f} rpm")
        print(f"total counts: D2 {totals[0]}, D3 {totals[1]}")


if __name__ == "__main__":
    anyio.run(main)
