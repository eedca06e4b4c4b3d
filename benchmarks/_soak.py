"""The soak core shared by ``benchmarks.soak`` (single calls) and ``benchmarks.tx_soak``
(transactions): many tasks on one board over a faulty line, every answer checked outside
the library.

:func:`run` opens a virtual Uno and a :class:`Board`, lets the caller read the truth on
the clean line, switches the harness's fault injector on (drop, insert and flip per
board->host byte), runs the tasks until the :class:`Tally` is spent and returns the
figures both soaks report.  Each task runs its calls through :func:`guarded`, which counts
documented library errors by class and hangs (a call still running after
:data:`HANG_GUARD` seconds, far beyond any timeout).
"""

from __future__ import annotations

import argparse
import collections
import os
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import anyio

from arduinoio_async.board import Board
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.sim import VirtualUno

__all__ = ["HANG_GUARD", "Tally", "guarded", "rss_kb", "run"]

HANG_GUARD = 5.0
T = TypeVar("T")


def rss_kb() -> int:
    """This process's resident memory (kB)."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


@dataclass
class Tally:
    """Calls left to issue, and what became of those issued."""

    total: int
    issued: int = 0
    ok: int = 0
    errors: collections.Counter[str] = field(default_factory=collections.Counter)
    wrong: list[str] = field(default_factory=list)
    hangs: int = 0
    #: Resident memory once a tenth of the calls were issued (growth is measured from it).
    rss_start: int | None = None

    def take(self) -> bool:
        """Claim one call; False once all were issued."""
        if self.issued >= self.total:
            return False
        self.issued += 1
        if self.rss_start is None and self.issued >= self.total // 10:
            self.rss_start = rss_kb()
        return True


async def guarded(tally: Tally, what: Callable[[], Awaitable[T]]) -> tuple[bool, T | None]:
    """Run one library call: (True, its result), or (False, None) when it raised or hung."""
    with anyio.move_on_after(HANG_GUARD) as guard:
        try:
            result = await what()
        except ArduinoIOError as exc:
            tally.errors[type(exc).__name__] += 1
            return False, None
        tally.ok += 1
        return True, result
    assert guard.cancelled_caught
    tally.hangs += 1
    return False, None


Prepare = Callable[[VirtualUno, Board], Awaitable[Any]]
#: Starts task ``index`` (of ``--tasks``) with the truth :data:`Prepare` read.
StartTask = Callable[[anyio.abc.TaskGroup, VirtualUno, Board, Any, int], None]


async def run(
    args: argparse.Namespace, tally: Tally, prepare: Prepare, start_task: StartTask
) -> dict[str, Any]:
    """One soak: ``args`` gives ``baud``, ``seed``, ``fault``, ``tasks`` and ``timeout``
    (the board's per-call timeout; None for the library's default)."""
    options = {} if args.timeout is None else {"timeout": args.timeout}
    async with (
        VirtualUno(board_id=0x0033, baud=args.baud, seed=args.seed) as uno,
        Board.open(uno.port, baudrate=args.baud, **options) as board,
    ):
        truth = await prepare(uno, board)
        await uno.set_faults(drop=args.fault, insert=args.fault, flip=args.fault, seed=args.seed)
        start = time.monotonic()
        load_start = os.getloadavg()[0]
        async with anyio.create_task_group() as tg:
            for index in range(args.tasks):
                start_task(tg, uno, board, truth, index)
        elapsed = time.monotonic() - start
        faults = (await uno.status())["faults"]
        stats = board.link.stats
    rss_end = rss_kb()
    return {
        "tasks": args.tasks,
        "baud": args.baud,
        "fault_probability": args.fault,
        "machine_load_1min": [round(load_start, 2), round(os.getloadavg()[0], 2)],
        "cpus": os.cpu_count(),
        "seconds": round(elapsed, 2),
        "succeeded": tally.ok,
        "errors": dict(tally.errors),
        "wrong_examples": tally.wrong[:10],
        "hangs": tally.hangs,
        "rss_growth_kb": rss_end - (tally.rss_start or rss_end),
        "injected": faults,
        "link_stats": stats.as_dict(),
    }
