"""Idle failsafe: does a healthy, idle host keep a 100 ms failsafe fed on a faulty line?

A virtual Uno runs under a :class:`BoardManager` (the robot's configuration: the manager's
keepalive re-arms after a trip and restores the outputs).  D4 is an output held high, armed
with safe level low and a ``--timeout-ms`` failsafe; then the harness drops, inserts and
flips board->host bytes with probability ``--fault`` each, and the host does nothing for
``--seconds`` but keep the board alive.  Every trip is a false one: the host is healthy.

Counted from the fixture (the ground truth, not the library): each fall of D4 is a trip
(the manager raises it again after re-arming).  Also recorded: the trips the library
reported, the link's statistics, the injected faults, and the simulated against the wall
clock (the harness may run ahead of the wall; the failsafe counts simulated time).  At the
end, with the line clean, the host's event loop is blocked and the board's reaction is
measured from the host's last byte, as the fixture saw it (the failsafe must still work).

On a loaded machine the OS may leave the host (or the virtual Uno) without the CPU for
longer than the timeout -- seen: 150-1000 ms stalls of an idle process at a load of 15 on
2 cores -- which trips the failsafe whatever the library does; run under ``chrt -r 10``
to measure the library rather than the machine (the result records the policy and the
load).  Several fault levels may run at once (one process each); each adds its level to
``--json`` under ``failsafe_false_trips_detail`` and re-sums ``failsafe_false_trips`` (and
``failsafe_false_trips_not_after_host_stall``)
(read-modify-write of these keys only, under a lock: other benchmarks own other keys)::

    chrt -r 10 .venv/bin/python -m benchmarks.idle_failsafe --fault 1e-3 --seconds 600 \\
        --json benchmarks/results/link.json
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D4
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim import VirtualUno
from arduinoio_async.transport import TraceRecord

from ._results import command_line, merge_result

BOARD_ID = 0x0028
#: How often the fixture's D4 capture is read while idling (costs the host nothing).
CHECK_EVERY = 5.0
#: The stall watcher's tick, and the lateness it records as a stall of the host process.
STALL_TICK = 0.005
STALL = 0.05
#: A trip the library reports within this long after a host stall of 3/4 of the timeout
#: (the heartbeat's interval is 1/4) is counted as one the stall explains.
STALL_TO_TRIP = 1.0


#: Link trace records kept for --trace-trips (about 25 s of an idle keepalive's traffic).
TRACE_KEPT = 2000
#: How much of the trace before a reported trip --trace-trips records.
TRACE_BEFORE_S = 1.5


def trace_before(records: collections.deque[TraceRecord], now_ns: int) -> list[str]:
    """The frames of the last TRACE_BEFORE_S seconds, each as ``ms-before-now dir item``."""
    since = now_ns - int(TRACE_BEFORE_S * 1e9)
    return [
        f"{(record.time_ns - now_ns) / 1e6:9.3f} {record.direction} {record.item!r}"
        for record in list(records)
        if record.time_ns >= since
    ]


async def watch_stalls(stalls: list[tuple[float, float]], stop: anyio.Event) -> None:
    """Record when (end, monotonic) and how long the host's event loop did not run: the
    OS (or the hypervisor) not running the process, which no keepalive can cover."""
    while not stop.is_set():
        before = time.monotonic()
        await anyio.sleep(STALL_TICK)
        now = time.monotonic()
        if stop.is_set():  # the host's deliberate stop at the end is not a stall
            return
        if now - before - STALL_TICK >= STALL:
            stalls.append((now, now - before - STALL_TICK))


async def run(args: argparse.Namespace) -> dict[str, Any]:
    events: list[ManagerEvent] = []
    trip_times: list[float] = []
    stalls: list[tuple[float, float]] = []

    recent: collections.deque[TraceRecord] = collections.deque(maxlen=TRACE_KEPT)
    trip_traces: list[list[str]] = []

    def on_event(event: ManagerEvent) -> None:
        events.append(event)
        if event.kind == "failsafe":
            trip_times.append(time.monotonic())
            if args.trace_trips:
                trip_traces.append(trace_before(recent, time.perf_counter_ns()))

    async with (
        VirtualUno(board_id=BOARD_ID, baud=args.baud, seed=args.seed) as uno,
        BoardManager(ports=[uno.port], usb=False, env=False, registered=False) as boards,
        anyio.create_task_group() as watchers,
    ):
        boards.subscribe(on_event)
        board = await boards.get(BOARD_ID, timeout=10)
        if args.trace_trips:
            board.link.trace = recent.append
        led = await board.digital_output(D4, initial=True)
        await board.arm_failsafe(args.timeout_ms, {led: False})
        await uno.clear_pulse_stats("D4")
        start_status = await uno.status()
        await uno.set_faults(drop=args.fault, insert=args.fault, flip=args.fault, seed=args.seed)
        start = time.monotonic()
        stop_watching = anyio.Event()
        watchers.start_soon(watch_stalls, stalls, stop_watching)
        trips_seen = 0
        loads = [os.getloadavg()[0]]
        while (left := args.seconds - (time.monotonic() - start)) > 0:
            await anyio.sleep(min(CHECK_EVERY, left))
            trips_seen = (await uno.pulse_stats("D4")).falls
            loads.append(os.getloadavg()[0])
            print(f"{time.monotonic() - start:7.1f} s: {trips_seen} trips", file=sys.stderr)
        elapsed = time.monotonic() - start
        stop_watching.set()
        await uno.set_faults(drop=0, insert=0, flip=0)
        end_status = await uno.status()
        d4 = await uno.pulse_stats("D4")
        with anyio.fail_after(10):
            while not board.connected:  # noqa: ASYNC110 - a restore may be under way
                await anyio.sleep(0.01)
        stats = board.link.stats.as_dict()
        reported = sum(1 for e in events if e.kind == "failsafe")
        resets = sum(1 for e in events if e.kind == "reset")
        # The host stops (its event loop blocks): the board must still react in time.
        with anyio.fail_after(5):
            while (await uno.pin("D4")).level != 1:  # noqa: ASYNC110 - a re-arm may be due
                await anyio.sleep(0.01)
        await uno.clear_pulse_stats("D4")
        time.sleep(args.timeout_ms / 1000 * 3)  # noqa: ASYNC251 - the host stops on purpose
        silent_from = float((await uno.status())["last_host_byte_us"])
        edge = (await uno.pulse_stats("D4")).last_edge_us
        reaction_ms = None if edge is None else round((edge - silent_from) / 1000, 3)
    long_stall = args.timeout_ms / 1000 * 0.75
    explained = sum(
        1
        for trip in trip_times
        if any(length >= long_stall and 0 <= trip - end <= STALL_TO_TRIP for end, length in stalls)
    )
    sim_s = (end_status["sim_us"] - start_status["sim_us"]) / 1e6
    wall_s = (end_status["wall_us"] - start_status["wall_us"]) / 1e6
    return {
        "fault_probability": args.fault,
        "timeout_ms": args.timeout_ms,
        "seconds": round(elapsed, 1),
        "false_trips": d4.falls,
        "trips_reported_by_library": reported,
        "resets_seen": resets,
        "host_stalls_over_50ms": len(stalls),
        "longest_host_stall_ms": round(max((n for _, n in stalls), default=0.0) * 1000, 1),
        "trips_right_after_a_host_stall": explained,
        **({"trip_traces": trip_traces} if args.trace_trips else {}),
        "reaction_when_host_stops_ms": reaction_ms,
        "sim_over_wall_clock": round(sim_s / wall_s, 4) if wall_s else None,
        "host_scheduling": scheduling(),
        "machine_load_1min": {
            "min": min(loads),
            "mean": round(sum(loads) / len(loads), 2),
            "max": max(loads),
            "cpus": os.cpu_count(),
        },
        "injected": end_status["faults"],
        "link_stats": stats,
        "baud": args.baud,
        "seed": args.seed,
        "command": command(args.argv),
    }


def command(argv: list[str]) -> str:
    """The command line that ran this, ``chrt`` included when the host ran real-time."""
    line = command_line(argv)
    policy = os.sched_getscheduler(0)
    if policy in (os.SCHED_RR, os.SCHED_FIFO):
        flag = "-r" if policy == os.SCHED_RR else "-f"
        line = f"chrt {flag} {os.sched_getparam(0).sched_priority} {line}"
    return line


def scheduling() -> str:
    """This process's CPU scheduling (the harness, its child, inherits it): under
    ``chrt -r 10`` a loaded machine cannot starve the host and the board of the CPU for
    longer than the failsafe's timeout, which no library could prevent."""
    policy = os.sched_getscheduler(0)
    names = {os.SCHED_OTHER: "SCHED_OTHER", os.SCHED_FIFO: "SCHED_FIFO", os.SCHED_RR: "SCHED_RR"}
    return f"{names.get(policy, policy)} priority {os.sched_getparam(0).sched_priority}"


def record(path: Path, level: dict[str, Any]) -> None:
    """Add this level to ``path``'s failsafe keys; every other key is left as it was."""

    def update(data: dict[str, Any]) -> None:
        detail = data.get("failsafe_false_trips_detail", {})
        detail[f"{level['fault_probability']:g}"] = level
        data["failsafe_false_trips_detail"] = detail
        data["failsafe_false_trips"] = sum(d["false_trips"] for d in detail.values())
        # Trips no stall of the host process explains: the library's own.
        data["failsafe_false_trips_not_after_host_stall"] = sum(
            max(0, d["false_trips"] - d.get("trips_right_after_a_host_stall", 0))
            for d in detail.values()
        )

    merge_result(path, update)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fault", type=float, default=1e-3)
    parser.add_argument("--seconds", type=float, default=600)
    parser.add_argument("--timeout-ms", type=int, default=100)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--trace-trips",
        action="store_true",
        help=f"record the link's frames in the {TRACE_BEFORE_S:g} s before each reported trip",
    )
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    args.argv = sys.argv[1:]
    result = anyio.run(run, args)
    print(json.dumps(result, indent=2))
    if args.json:
        record(args.json, result)


if __name__ == "__main__":
    main()
