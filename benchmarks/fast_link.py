"""Fast links without a bridge: one request's round trip, and pipelined writes per second.

The "no bridge" speed goals: sequential read ID p50 at most 0.15 ms at 2,000,000 baud
through the library, and the host's share of pipelined write-pin at least 28,000/s.

*Round trips* (``await board.read_id()`` one after another): on one virtual Uno per baud
rate, three clients take turns in rounds whose order rotates every round, so a busy
neighbour on the shared machine slows all of them alike: bare pyserial
(``write(3)`` + ``read(5)``, blocking, the floor any Python client pays), a minimal asyncio
client (a reader callback resolving one future: the event loop's own floor) and the
library (the reference clients of :mod:`arduinoio_async.bench.clients`).  Each round
opens its client afresh (the port is exclusive), warms up, then takes ``--samples``
round trips.  Reported: p10/p50/p90 of all samples (:mod:`arduinoio_async.bench.stats`),
and the per-round medians' range as the spread.  ``--compare-harness PATH`` runs the
same clients on a second virtual Uno from another harness binary (an older build) in the
same rotation, so a harness change is measured before/after under the same load.

``--cpu-idle both`` runs every client (round trips and pipelined) once with the CPUs'
default idle states and once held out of deep idle states (PM QoS, see
:mod:`arduinoio_async.bench.cpu_idle`; needs root), in the same rotation: a halted CPU
of this VM takes ~70 us to wake, several times per round trip, and the figures report
which condition they were measured under.

*Pipelined writes* (``--tasks`` tasks each ``await gpio.write(...)`` in a loop) against
responder processes on pseudo-terminals
(:func:`arduinoio_async.bench.responder.pty_responder`): one that answers at once, many
replies per write (what the library alone can do, syscalls included), and one paced like
a firmware doing ``--paced-rate`` commands a second, each reply in its own write (the
host then wakes for every reply, as with the virtual Uno); and against the virtual Uno
at each baud rate (where the firmware's cycles per command limit the rate).  Rounds
interleave all of them; reported: median writes/s with the range, and the library's
CPU time per write (this thread's ``time.thread_time``: the host's own share, which a
busy neighbour on the shared machine disturbs far less than the wall-clock rate).

    .venv/bin/python -m benchmarks.fast_link --cpu-idle both \
        --json benchmarks/results/fast_link.json
"""

from __future__ import annotations

import argparse
import json
import os
import time
from contextlib import AsyncExitStack
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.bench import cpu_idle
from arduinoio_async.bench.clients import CLIENTS
from arduinoio_async.bench.cpu_idle import ShallowCpuIdle
from arduinoio_async.bench.responder import pty_responder
from arduinoio_async.bench.stats import median, percentile
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result

PIN = DigitalPin(4)


def _percentiles(values: list[float]) -> dict[str, float]:
    return {
        "p10": round(percentile(values, 0.1), 1),
        "p50": round(percentile(values, 0.5), 1),
        "p90": round(percentile(values, 0.9), 1),
    }


async def round_trips(
    baud: int,
    rounds: int,
    samples: int,
    warmup: int,
    compare: Path | None,
    idle: ShallowCpuIdle,
    conditions: list[str],
) -> dict[str, Any]:
    """Every client on this harness (and, with ``compare``, on that harness binary too:
    a second virtual Uno whose rounds interleave with the first's), under each CPU idle
    condition."""
    harnesses: dict[str, Path | None] = {"": None}
    if compare is not None:
        harnesses["harness_compared"] = compare
    pooled: dict[tuple[str, str, str], list[float]] = {}
    medians: dict[tuple[str, str, str], list[float]] = {}
    status: dict[str, dict[str, Any]] = {}
    async with AsyncExitStack() as stack:
        unos = {
            key: await stack.enter_async_context(VirtualUno(board_id=1, baud=baud, binary=binary))
            for key, binary in harnesses.items()
        }
        before = {key: await uno.status() for key, uno in unos.items()}
        order = [(key, client, cond) for key in unos for client in CLIENTS for cond in conditions]
        for index in range(rounds):
            shift = index % len(order)
            for key, client, cond in order[shift:] + order[:shift]:
                idle.set(cond)
                got = await CLIENTS[client](unos[key].port, baud, samples, warmup)
                pooled.setdefault((key, client, cond), []).extend(got.rtts_us)
                medians.setdefault((key, client, cond), []).append(median(got.rtts_us))
        idle.release()
        for key, uno in unos.items():
            after = await uno.status()
            status[key] = {
                name: after[name] - before[key][name]
                for name in ("rebases", "pty_writes", "runahead_jumps")
                if isinstance(after.get(name), int)
            }
    out: dict[str, Any] = {"baud": baud, "cpu_idle": {}}
    for cond in conditions:
        under = out["cpu_idle"].setdefault(cond, {})
        for key in harnesses:
            part = under if not key else under.setdefault(key, {"binary": str(compare)})
            for client in CLIENTS:
                values = medians[(key, client, cond)]
                part[client] = {
                    **_percentiles(pooled[(key, client, cond)]),
                    "round_medians_range": [round(min(values), 1), round(max(values), 1)],
                    "samples": len(pooled[(key, client, cond)]),
                }
            part["harness"] = status[key]  # both conditions: they share the boards
    return out


async def _write_rate(port_path: str, baud: int, calls: int, tasks: int) -> tuple[float, float]:
    """``calls`` pipelined writes from ``tasks`` tasks: (writes per second of wall time,
    microseconds of this thread's CPU time per write)."""
    async with Board.open(port_path, baudrate=baud, timeout=2.0) as board:
        gpio = board.gpio(PIN)
        await gpio.write(False)
        remaining = calls
        level = False

        async def worker() -> None:
            nonlocal remaining, level
            while remaining > 0:
                remaining -= 1
                level = not level
                await gpio.write(level)

        begin = time.perf_counter()
        cpu = time.thread_time()
        async with anyio.create_task_group() as tg:
            for _ in range(tasks):
                tg.start_soon(worker)
        cpu = time.thread_time() - cpu
        return calls / (time.perf_counter() - begin), cpu / calls * 1e6


async def pipelined(
    bauds: list[int],
    rounds: int,
    calls: int,
    tasks: int,
    paced_rate: float,
    compare: Path | None,
    idle: ShallowCpuIdle,
    conditions: list[str],
) -> dict[str, Any]:
    paced = f"responder_paced_{paced_rate:.0f}_per_s"
    ports: dict[str, tuple[str, int]] = {}
    async with AsyncExitStack() as stack:
        ports["responder_instant"] = (stack.enter_context(pty_responder(0.0)), 2_000_000)
        ports[paced] = (stack.enter_context(pty_responder(1 / paced_rate)), 2_000_000)
        for baud in bauds:
            uno = await stack.enter_async_context(VirtualUno(board_id=1, baud=baud))
            ports[f"virtual_uno_{baud}"] = (uno.port, baud)
            if compare is not None:
                uno = await stack.enter_async_context(
                    VirtualUno(board_id=1, baud=baud, binary=compare)
                )
                ports[f"virtual_uno_{baud}_harness_compared"] = (uno.port, baud)
        runs = [(name, cond) for name in ports for cond in conditions]
        rates: dict[tuple[str, str], list[float]] = {run: [] for run in runs}
        cpu: dict[tuple[str, str], list[float]] = {run: [] for run in runs}
        for index in range(rounds):
            shift = index % len(runs)
            for name, cond in runs[shift:] + runs[:shift]:
                idle.set(cond)
                rate, cpu_us = await _write_rate(*ports[name], calls, tasks)
                rates[name, cond].append(rate)
                cpu[name, cond].append(cpu_us)
        idle.release()
    return {
        "tasks": tasks,
        "calls_per_round": calls,
        "cpu_idle": {
            cond: {name: _rate_figures(rates[name, cond], cpu[name, cond]) for name in ports}
            for cond in conditions
        },
    }


def _rate_figures(rates: list[float], cpu: list[float]) -> dict[str, Any]:
    return {
        "writes_per_s_median": round(median(rates)),
        "writes_per_s_range": [round(min(rates)), round(max(rates))],
        "library_cpu_us_per_write_median": round(median(cpu), 2),
        "library_cpu_us_per_write_range": [round(min(cpu), 2), round(max(cpu), 2)],
        "writes_per_library_cpu_second": round(1e6 / median(cpu)),
    }


async def measure(
    args: argparse.Namespace, idle: ShallowCpuIdle, conditions: list[str]
) -> dict[str, Any]:
    result: dict[str, Any] = {
        "command": command_line(),
        "cpus": os.cpu_count(),
        "load_average_before": os.getloadavg(),
        "round_trips_us": [],
    }
    for baud in args.bauds:
        trips = await round_trips(
            baud, args.rounds, args.samples, args.warmup, args.compare_harness, idle, conditions
        )
        result["round_trips_us"].append(trips)
        print(json.dumps(trips), flush=True)
    if args.calls:
        result["pipelined_write_pin"] = await pipelined(
            args.bauds,
            args.rounds,
            args.calls,
            args.tasks,
            args.paced_rate,
            args.compare_harness,
            idle,
            conditions,
        )
        print(json.dumps(result["pipelined_write_pin"]), flush=True)
    result["load_average_after"] = os.getloadavg()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bauds", type=int, nargs="+", default=[1_000_000, 2_000_000])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--samples", type=int, default=400)
    parser.add_argument("--warmup", type=int, default=50)
    parser.add_argument("--calls", type=int, default=20_000, help="writes per pipelined round")
    parser.add_argument("--tasks", type=int, default=32)
    parser.add_argument(
        "--paced-rate", type=float, default=30_000, help="replies/s of the paced responder"
    )
    parser.add_argument(
        "--compare-harness",
        type=Path,
        help="also run the round trips on this virtual-uno binary, interleaved (before/after)",
    )
    cpu_idle.add_option(parser, interleave=True)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    idle, conditions = cpu_idle.conditions(parser, args.cpu_idle)
    result = anyio.run(measure, args, idle, conditions)
    if args.json:
        write_result(args.json, result)


if __name__ == "__main__":
    main()
