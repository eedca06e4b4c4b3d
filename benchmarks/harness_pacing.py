"""Does the virtual Uno keep up with the wall clock when many boards work at once?

Each board answers ``--burst`` pipelined GPIO WRITEs every ``--period-ms`` (a control loop
writing several outputs per cycle) for ``--seconds``; the harness reports how often it fell
more than 50 ms behind the wall clock and gave up catching up (``rebases``) and its worst
lag.  That depends on how many cores the machine can spare, so it is measured here and
recorded, not asserted in the test suite (which checks that every command is answered).

    .venv/bin/python -m benchmarks.harness_pacing --boards 8 --rounds 3 \\
        --json benchmarks/results/harness_pacing.json
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path
from typing import Any

import anyio
import serial

from arduinoio_async import protocol as p
from arduinoio_async.sim import find_firmware_elf, start_virtual_unos

from ._results import command_line, write_result


def bursts(port: str, baud: int, seconds: float, burst: int, period: float) -> int:
    """Blocking pyserial client (run in a worker thread); returns the commands answered."""
    link = serial.Serial(port, baud, timeout=2.0)
    try:
        link.write(p.GpioConfig(4, p.GpioFlags.OUTPUT).encode())
        if len(link.read(5)) != 5:
            raise RuntimeError(f"{port}: no reply to GPIO CONFIG")
        request = p.GpioWrite(4, True).encode()
        expected = p.GpioWriteReply(4, True).encode() * burst
        done, due = 0, time.monotonic()
        end = due + seconds
        while due < end:
            link.write(request * burst)
            if link.read(len(expected)) != expected:
                raise RuntimeError(f"{port}: wrong or missing replies after {done}")
            done += burst
            due += period
            time.sleep(max(0.0, due - time.monotonic()))
        return done
    finally:
        link.close()


async def one_round(
    boards: int, baud: int, seconds: float, burst: int, period: float
) -> dict[str, Any]:
    async with start_virtual_unos(list(range(1, boards + 1)), baud=baud) as unos:
        before = [await uno.status() for uno in unos]
        counts = [0] * boards

        async def load(i: int) -> None:
            counts[i] = await anyio.to_thread.run_sync(
                bursts, unos[i].port, unos[i].baud, seconds, burst, period
            )

        async with anyio.create_task_group() as tg:
            for i in range(boards):
                tg.start_soon(load, i)
        after = [await uno.status() for uno in unos]
    return {
        "commands_per_s": sum(counts) / seconds,
        "rebases": [a["rebases"] - b["rebases"] for a, b in zip(after, before, strict=True)],
        "max_lag_us": max(a["max_lag_us"] for a in after),
    }


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=int, default=8)
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--burst", type=int, default=8)
    parser.add_argument("--period-ms", type=float, default=20.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    find_firmware_elf(args.baud)
    rounds = []
    for i in range(args.rounds):
        result = await one_round(
            args.boards, args.baud, args.seconds, args.burst, args.period_ms / 1000
        )
        rounds.append(result)
        print(
            f"round {i + 1}: {result['commands_per_s']:.0f} cmd/s, rebases {result['rebases']}, "
            f"max lag {result['max_lag_us']:.0f} us"
        )
    lags = [r["max_lag_us"] for r in rounds]
    summary = {
        "command": command_line(),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
        "rounds": rounds,
        "rounds_without_rebase": sum(not any(r["rebases"]) for r in rounds),
        "max_lag_us_median": statistics.median(lags),
        "max_lag_us_range": [min(lags), max(lags)],
    }
    print(
        f"{summary['rounds_without_rebase']}/{args.rounds} rounds without a rebase; worst lag "
        f"median {summary['max_lag_us_median']:.0f} us ({min(lags):.0f}-{max(lags):.0f})"
    )
    if args.json:
        write_result(args.json, summary)


if __name__ == "__main__":
    anyio.run(main)
