"""Record four analog channels at 1 kHz, sampled by the board's timer, to CSV (and a plot).

    python examples/stream_to_csv.py [--port P] [--baud 1000000] [--seconds 2] [--csv out.csv]

The board samples from its timer interrupt and pushes every sample with a sequence number,
so the timing is the board's, not the host's, and a lost sample is counted as a gap.  Four
channels at 1 kHz need 1,000,000 baud; at the paper's 115200 the board refuses the stream
with a LinkCapacityError that names the shortest period it can carry.
"""

from __future__ import annotations

import csv
from pathlib import Path

import anyio

from arduinoio_async import A0, A1, A2, A3
from arduinoio_async.sim import example_arguments, example_board

CHANNELS = (A0, A1, A2, A3)


async def main() -> None:
    parser = example_arguments(__doc__)
    parser.set_defaults(baud=1_000_000)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--period-ms", type=float, default=1.0)
    parser.add_argument("--csv", type=Path, default=Path("stream.csv"))
    parser.add_argument("--plot", type=Path, help="also save a PNG plot (needs matplotlib)")
    args = parser.parse_args()
    rows: list[tuple[float, ...]] = []
    async with (
        example_board(args, fixture="r2r") as board,
        board.stream(analog=CHANNELS, period_ms=args.period_ms) as samples,
    ):
        with anyio.move_on_after(args.seconds):
            async for s in samples:
                rows.append((s.sequence, s.board_time_us, *(s.analog[pin] for pin in CHANNELS)))
    with args.csv.open("w", newline="") as out:
        writer = csv.writer(out)
        writer.writerow(["sequence", "board_time_us", *(pin.name for pin in CHANNELS)])
        writer.writerows(rows)
    print(
        f"wrote {len(rows)} samples to {args.csv}; gaps {samples.gaps}, dropped {samples.dropped}"
    )
    if args.plot:
        plot(rows, args.plot)


def plot(rows: list[tuple[float, ...]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = rows[0][1]
    times = [(row[1] - t0) / 1000 for row in rows]
    fig, ax = plt.subplots(figsize=(8, 3))
    for n, pin in enumerate(CHANNELS):
        ax.plot(times, [row[2 + n] for row in rows], label=pin.name)
    ax.set_xlabel("board time (ms)")
    ax.set_ylabel("ADC counts")
    ax.legend()
    fig.savefig(path, dpi=100, bbox_inches="tight")
    print(f"plot saved to {path}")


if __name__ == "__main__":
    anyio.run(main)
