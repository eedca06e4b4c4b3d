"""The library's CPU per pipelined write, this tree against another checkout, interleaved.

Why: a recorded figure from another day cannot tell a regression from a slower machine
(this shared VM's speed drifts by 2x within a day).  Running two package trees in one
run, in alternating order, on the same responder, can: a neighbour's burst slows both.

Each round runs each tree's client in a fresh process (its own import of its own
``arduinoio_async``): ``--tasks`` tasks ``await gpio.write(...)`` in a loop, ``--calls``
writes in all, at 2,000,000 baud, against that tree's own instant responder on a
pseudo-terminal (it answers every request one read brought in one write; the responder
runs in another process, so its CPU does not count).  Reported per tree: the median
writes/s and the median of this thread's CPU time per write (``time.thread_time``), with
their ranges.  The other tree needs only its sources (``git worktree add DIR COMMIT``);
both run with this environment's interpreter and dependencies.

    .venv/bin/python -m benchmarks.compare_trees /work/wt-old --rounds 6 \
        --json benchmarks/results/compare_trees.json
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

from ._results import command_line, write_result

HERE = Path(__file__).resolve().parents[1]

#: The client each tree runs: a fresh process started in that tree with it on PYTHONPATH
#: (ahead of an editable install's finder); the package it imported is checked.
CLIENT = r"""
import sys, time, anyio
import arduinoio_async
from arduinoio_async import Board, D13
port, calls, tasks = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
async def main():
    async with Board.open(port, baudrate=2_000_000, timeout=2.0) as board:
        gpio = board.gpio(D13)
        await gpio.write(False)
        remaining = calls
        async def worker():
            nonlocal remaining
            level = False
            while remaining > 0:
                remaining -= 1
                level = not level
                await gpio.write(level)
        begin, cpu = time.perf_counter(), time.thread_time()
        async with anyio.create_task_group() as tg:
            for _ in range(tasks):
                tg.start_soon(worker)
        cpu = time.thread_time() - cpu
        print(calls / (time.perf_counter() - begin), cpu / calls * 1e6, arduinoio_async.__file__)
anyio.run(main)
"""


def _responder_command(root: Path, fd: int) -> list[str]:
    """The tree's own instant responder: the benchmark's in trees that had one there (up to
    2026-11-24), else the package's."""
    script = root / "benchmarks" / "fast_link.py"
    if script.exists() and '"--serve"' in script.read_text():
        return [sys.executable, str(script), "--serve", str(fd)]
    return [sys.executable, "-m", "arduinoio_async.bench.responder", str(fd), "0"]


def one_run(root: Path, calls: int, tasks: int) -> tuple[float, float]:
    """(writes/s, library CPU us per write) of one client run of ``root``'s package."""
    master, slave = os.openpty()
    env = {**os.environ, "PYTHONPATH": str(root)}
    child = subprocess.Popen(
        _responder_command(root, master), pass_fds=(master,), env=env, cwd=root
    )
    os.close(master)
    try:
        args = [sys.executable, "-c", CLIENT, os.ttyname(slave), str(calls), str(tasks)]
        done = subprocess.run(
            args, capture_output=True, text=True, timeout=300, check=False, env=env, cwd=root
        )
        if done.returncode != 0:
            raise SystemExit(f"{root}: client failed: {done.stderr.strip().splitlines()[-1]}")
        rate, cpu, where = done.stdout.split()
        if not where.startswith(str(root)):
            raise SystemExit(f"{root}: imported {where}, not this tree's package")
        return float(rate), float(cpu)
    finally:
        os.close(slave)
        child.terminate()
        child.wait()


def summary(runs: list[tuple[float, float]]) -> dict[str, Any]:
    rates, cpus = [r for r, _ in runs], [c for _, c in runs]
    return {
        "writes_per_s_median": round(statistics.median(rates)),
        "writes_per_s_range": [round(min(rates)), round(max(rates))],
        "library_cpu_us_per_write_median": round(statistics.median(cpus), 2),
        "library_cpu_us_per_write_range": [round(min(cpus), 2), round(max(cpus), 2)],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("other", type=Path, help="the other checkout's root")
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--calls", type=int, default=20_000)
    parser.add_argument("--tasks", type=int, default=32)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    trees = {"this": HERE, "other": args.other.resolve()}
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in trees}
    for index in range(args.rounds):
        order = list(trees) if index % 2 == 0 else list(reversed(trees))
        for name in order:
            runs[name].append(one_run(trees[name], args.calls, args.tasks))
            rate, cpu = runs[name][-1]
            print(f"round {index + 1} {name}: {rate:,.0f} writes/s, {cpu:.2f} us CPU a write")
    result: dict[str, Any] = {
        "command": command_line(argv),
        "load_avg_1min_at_end": os.getloadavg()[0],
        "rounds": args.rounds,
        "calls_per_round": args.calls,
        "tasks": args.tasks,
        "other_tree": str(trees["other"]),
        **{name: summary(values) for name, values in runs.items()},
    }
    for name in trees:
        print(name, result[name])
    if args.json:
        write_result(args.json, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
