"""Soak: many tasks, a faulty line, every answer checked outside the library.

A virtual Uno at ``--baud`` drops, inserts and flips board->host bytes with probability
``--fault`` each (the harness's ``--fault-*`` injector, switched on after the handshake).
``--tasks`` tasks share one :class:`Board` until ``--commands`` calls were made:

* ten tasks own one output pin each (D4-D13) and toggle it; after every write that
  returned, the harness's pin probe (the fixture, not the library) must show the level;
* the others read the board ID, analog channels whose input the fixture sets, and the
  chip temperature, and compare with the values read on the clean line before the faults.

Counted: calls that returned (success), documented library errors by class, wrong answers
(a returned value the fixture contradicts), hangs (a call that did not end within
``HANG_GUARD`` seconds, far beyond any timeout) and the growth of the process's resident
memory from the first tenth of the run to the end.  Recorded, never asserted:

    .venv/bin/python benchmarks/soak.py --commands 100000 --json benchmarks/results/soak.json
"""

from __future__ import annotations

import argparse
import collections
import functools
import json
import sys
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async.board import Board
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.protocol.pins import AnalogPin, DigitalPin
from arduinoio_async.sim import VirtualUno

HANG_GUARD = 5.0
OUTPUT_PINS = [DigitalPin(n) for n in range(4, 14)]
ANALOG = {AnalogPin.A0: 1000.0, AnalogPin.A1: 2500.0, AnalogPin.A2: 4000.0}


def rss_kb() -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


class Tally:
    def __init__(self, total: int) -> None:
        self.remaining = total
        self.issued = 0
        self.ok = 0
        self.errors: collections.Counter[str] = collections.Counter()
        self.wrong: list[str] = []
        self.hangs = 0
        self.rss_start: int | None = None
        self.total = total

    def take(self) -> bool:
        if self.remaining <= 0:
            return False
        self.remaining -= 1
        self.issued += 1
        if self.rss_start is None and self.issued >= self.total // 10:
            self.rss_start = rss_kb()
        return True


async def call(tally: Tally, what: Callable[[], Awaitable[Any]]) -> tuple[bool, Any]:
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


async def pin_task(board: Board, uno: VirtualUno, pin: DigitalPin, tally: Tally) -> None:
    gpio = board.gpio(pin)
    level = False
    step = 0
    while tally.take():
        step += 1
        if step % 2:
            level = not level
            value = level
            # Only a write that returned is checked: a failed one may or may not have
            # happened.
            ok, _ = await call(tally, functools.partial(gpio.write, value))
            if ok:
                seen = await uno.pin(int(pin))
                if seen.level != int(value):
                    tally.wrong.append(f"D{int(pin)} written {value} but reads {seen.level}")
        else:
            ok, board_id = await call(tally, board.read_id)
            if ok and board_id != board.board_id:
                tally.wrong.append(f"read_id {board_id:#x}")


async def reader_task(board: Board, truth: dict[str, Any], index: int, tally: Tally) -> None:
    step = index
    pins = list(ANALOG)
    while tally.take():
        step += 1
        kind = step % 3
        if kind == 0:
            pin = pins[step // 3 % len(pins)]
            ok, value = await call(tally, board.analog(pin).read)
            if ok and value != truth[pin.name]:
                tally.wrong.append(f"{pin.name} read {value}, fixture gives {truth[pin.name]}")
        elif kind == 1:
            ok, celsius = await call(tally, board.temperature)
            if ok and celsius != truth["temperature"]:
                tally.wrong.append(f"temperature {celsius}")
        else:
            ok, board_id = await call(tally, board.read_id)
            if ok and board_id != truth["id"]:
                tally.wrong.append(f"read_id {board_id:#x}")


async def soak(args: argparse.Namespace) -> dict[str, Any]:
    tally = Tally(args.commands)
    async with (
        VirtualUno(board_id=0x0033, baud=args.baud, seed=args.seed) as uno,
        Board.open(uno.port, baudrate=args.baud) as board,
    ):
        for pin, mv in ANALOG.items():
            await uno.set_analog(int(pin), mv)
        truth: dict[str, Any] = {pin.name: await board.analog(pin).read() for pin in ANALOG}
        truth["temperature"] = await board.temperature()
        truth["id"] = await board.read_id()
        await uno.set_faults(drop=args.fault, insert=args.fault, flip=args.fault, seed=args.seed)
        start = time.monotonic()
        async with anyio.create_task_group() as tg:
            for index in range(args.tasks):
                if index < min(len(OUTPUT_PINS), args.tasks - 3):
                    tg.start_soon(pin_task, board, uno, OUTPUT_PINS[index], tally)
                else:
                    tg.start_soon(reader_task, board, truth, index, tally)
        elapsed = time.monotonic() - start
        faults = (await uno.status())["faults"]
        stats = board.link.stats
    rss_end = rss_kb()
    total = tally.issued
    return {
        "command": "benchmarks/soak.py " + " ".join(args.argv),
        "commands": total,
        "tasks": args.tasks,
        "baud": args.baud,
        "fault_probability": args.fault,
        "seconds": round(elapsed, 2),
        "commands_per_s": round(total / elapsed, 1),
        "succeeded": tally.ok,
        "success_rate": tally.ok / total,
        "errors": dict(tally.errors),
        "wrong_answers": len(tally.wrong),
        "wrong_examples": tally.wrong[:10],
        "hangs": tally.hangs,
        "rss_growth_kb": rss_end - (tally.rss_start or rss_end),
        "injected": faults,
        "link_stats": stats.as_dict(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--commands", type=int, default=100_000)
    parser.add_argument("--tasks", type=int, default=13)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--fault", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    args.argv = sys.argv[1:]
    result = anyio.run(soak, args)
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
