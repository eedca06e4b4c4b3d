"""Peer test (a) "host sets D2 -> host knows D3" at the fast baud rates.

The peer benchmark (``benchmarks.peers.peer_bench``) runs the project at 115200 baud,
where each way's byte count decides; this runs the same four client functions on the
project's 1,000,000 and 2,000,000 baud builds, with and without the 16U2 bridge model,
in rounds that interleave ways and links (a busy moment of the shared machine hits all).

    .venv/bin/python -m benchmarks.set_and_know_fast \\
        --json benchmarks/results/set_and_know_fast.json
"""

from __future__ import annotations

import argparse
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.bench.stats import summarize
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result
from .peers.peer_bench import project_a, project_a_event, project_a_transaction

Way = Callable[[VirtualUno, int], Awaitable[list[float]]]
WAYS: dict[str, Way] = {
    "write, then read": lambda uno, n: project_a(uno, n, False),
    "write + read pipelined": lambda uno, n: project_a(uno, n, True),
    "write + change event": project_a_event,
    "write + read in one transaction": project_a_transaction,
}


def figures(samples: list[float]) -> dict[str, Any]:
    """n, p50, p90, mean (:mod:`arduinoio_async.bench.stats`) and max - min, in ms."""
    summary = summarize(samples).rounded(3, "_ms")
    del summary["p99_ms"]
    return {**summary, "spread_ms": round(max(samples) - min(samples), 3)}


async def main(args: argparse.Namespace) -> int:
    samples: dict[tuple[int, str, str], list[float]] = {}
    per_round = max(1, args.n // args.rounds)
    for r in range(args.rounds):
        for baud in args.bauds:
            for link in ("none", "16u2"):
                async with VirtualUno(
                    fixture="loopback", usb_bridge=link, baud=baud, board_id=1
                ) as uno:
                    for name, way in WAYS.items():
                        got = await way(uno, per_round)
                        samples.setdefault((baud, link, name), []).extend(got)
        print(f"round {r + 1} of {args.rounds} done", flush=True)
    rows: list[dict[str, Any]] = [
        {"baud": baud, "link": link, "way": name, **figures(values)}
        for (baud, link, name), values in sorted(samples.items())
    ]
    print("| baud | link | way | n | p50 ms | p90 ms | mean ms |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print(
            f"| {row['baud']:,} | {row['link']} | {row['way']} | {row['n']} | "
            f"{row['p50_ms']:.2f} | {row['p90_ms']:.2f} | {row['mean_ms']:.2f} |"
        )
    if args.json:
        write_result(args.json, {"command": command_line(), "rows": rows})
    return 0


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--bauds", type=int, nargs="+", default=[1_000_000, 2_000_000])
    return parser.parse_args()


if __name__ == "__main__":
    raise SystemExit(anyio.run(main, parse_args()))
