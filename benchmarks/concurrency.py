"""Call order against wire order: many tasks toggling one pin through one Board.

Each call takes the next level of a strict alternation *when it is made* (call order);
runs with one task, with 12 (the benchmark's pipelined scenario: as many as fit the
window) and with ``--tasks``;
the harness counts the edges the pin really made (the fixture, not the library).  With
wire order = call order every call is an edge; each call that overtakes another costs
edges.  Also counted: timeouts at the default timeout, and the rate against one task.

    .venv/bin/python -m benchmarks.concurrency --json benchmarks/results/concurrency.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.board import Board
from arduinoio_async.errors import BoardTimeoutError, LinkError
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim import VirtualUno

from ._results import command_line, report

PIN = DigitalPin(2)


async def measure(args: argparse.Namespace) -> dict[str, Any]:
    async with (
        VirtualUno(board_id=1, baud=args.baud) as uno,
        Board.open(uno.port, baudrate=args.baud) as board,
    ):
        gpio = board.gpio(PIN)
        await gpio.write(False)
        level = False
        timeouts = errors = 0

        async def worker(calls: int) -> None:
            nonlocal level, timeouts, errors
            for _ in range(calls):
                level = not level
                try:
                    await gpio.write(level)
                except BoardTimeoutError:
                    timeouts += 1
                except LinkError:
                    errors += 1

        async def run(tasks: int) -> tuple[int, float, int]:
            await uno.clear_pulse_stats(int(PIN))
            before = await uno.pulse_stats(int(PIN))
            begin = time.perf_counter()
            async with anyio.create_task_group() as tg:
                for _ in range(tasks):
                    tg.start_soon(worker, args.calls // tasks)
            elapsed = time.perf_counter() - begin
            after = await uno.pulse_stats(int(PIN))
            edges = (after.count + after.falls) - (before.count + before.falls)
            return edges, elapsed, args.calls // tasks * tasks

        single_edges, single_s, single_calls = await run(1)
        # The benchmark's pipelined scenario: as many tasks as requests fit the window.
        window_edges, window_s, window_calls = await run(12)
        many_edges, many_s, many_calls = await run(args.tasks)
    return {
        "command": command_line(),
        "baud": args.baud,
        "tasks": args.tasks,
        "single_task": {
            "calls": single_calls,
            "edges": single_edges,
            "calls_per_s": round(single_calls / single_s),
        },
        "pipelined_12_tasks": {
            "calls": window_calls,
            "edges": window_edges,
            "calls_per_s": round(window_calls / window_s),
        },
        "many_tasks": {
            "calls": many_calls,
            "edges": many_edges,
            "calls_not_in_call_order": many_calls - many_edges,
            "calls_per_s": round(many_calls / many_s),
        },
        "timeouts": timeouts,
        "other_link_errors": errors,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=32)
    parser.add_argument("--calls", type=int, default=9600)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args)
    report(result, args.json)


if __name__ == "__main__":
    main()
