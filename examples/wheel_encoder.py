"""Two quadrature wheel encoders: position, direction and speed, decoded by the board.

    python examples/wheel_encoder.py [--port P] [--seconds 2] [--counts-per-rev 1200]

Left encoder: A on D2, B on D3 (INT0/INT1); right: A on D4, B on D5 (pin-change
interrupts). The board counts every edge of both channels (x4) in interrupts, so no step
is lost however slowly this loop reads, and the sign of the count is the direction.  The
speed comes from the board's time of the last counting edge of each read
(``velocity_since``), so it is exact over whole edges whatever the host's timing.
Wiring and limits: docs/sensors.md.
"""

from __future__ import annotations

import anyio

from arduinoio_async import D2, D3, D4, D5
from arduinoio_async.sim import example_arguments, example_board


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--counts-per-rev", type=int, default=1200)
    args = parser.parse_args()
    async with example_board(args, fixture="open") as board:
        left = await board.encoder(a=D2, b=D3)
        right = await board.encoder(a=D4, b=D5)
        before = [await left.read(), await right.read()]
        interval = 0.25
        print("ready: turn the wheels", flush=True)
        for _ in range(round(args.seconds / interval)):
            await anyio.sleep(interval)
            now = [await left.read(), await right.read()]
            rpm = [
                s.velocity_since(b) / args.counts_per_rev * 60
                for s, b in zip(now, before, strict=True)
            ]
            counts = f"({now[0].count:+d} / {now[1].count:+d} counts)"
            print(f"left {rpm[0]:+7.1f} rpm   right {rpm[1]:+7.1f} rpm   {counts}")
            before = now
        final = [await left.read(), await right.read()]
        print(f"total counts: left {final[0].count}, right {final[1].count}")
        if final[0].invalid or final[1].invalid:
            print(f"invalid transitions: left {final[0].invalid}, right {final[1].invalid}")


if __name__ == "__main__":
    anyio.run(main)
