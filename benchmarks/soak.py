"""Soak: many tasks, a faulty line, every answer checked outside the library.

A virtual Uno at ``--baud`` drops, inserts and flips board->host bytes with probability
``--fault`` each (the harness's ``--fault-*`` injector, switched on after the handshake).
``--tasks`` tasks share one :class:`Board` until ``--commands`` calls were made:

* ten tasks own one output pin each (D4-D13) and toggle it; after every write that
  returned, the harness's pin probe (the fixture, not the library) must show the level;
* the others read the board ID, analog channels whose input the fixture sets, and the
  chip temperature, and compare with the values read on the clean line before the faults.

Counted (the core is :mod:`benchmarks._soak`, shared with ``benchmarks.tx_soak``): calls
that returned (success), documented library errors by class, wrong answers (a returned
value the fixture contradicts), hangs (a call that did not end within ``HANG_GUARD``
seconds, far beyond any timeout) and the growth of the process's resident memory from
the first tenth of the run to the end.  Recorded, never asserted:

    .venv/bin/python -m benchmarks.soak --commands 100000 --json benchmarks/results/soak.json
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any

import anyio
import anyio.abc

from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import AnalogPin, DigitalPin
from arduinoio_async.sim import VirtualUno

from . import _soak
from ._results import command_line, report
from ._soak import Tally, guarded

OUTPUT_PINS = [DigitalPin(n) for n in range(4, 14)]
ANALOG = {AnalogPin.A0: 1000.0, AnalogPin.A1: 2500.0, AnalogPin.A2: 4000.0}


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
            ok, _ = await guarded(tally, functools.partial(gpio.write, value))
            if ok:
                seen = await uno.pin(int(pin))
                if seen.level != int(value):
                    tally.wrong.append(f"D{int(pin)} written {value} but reads {seen.level}")
        else:
            ok, board_id = await guarded(tally, board.read_id)
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
            ok, value = await guarded(tally, board.analog(pin).read)
            if ok and value != truth[pin.name]:
                tally.wrong.append(f"{pin.name} read {value}, fixture gives {truth[pin.name]}")
        elif kind == 1:
            ok, celsius = await guarded(tally, board.temperature)
            if ok and celsius != truth["temperature"]:
                tally.wrong.append(f"temperature {celsius}")
        else:
            ok, board_id = await guarded(tally, board.read_id)
            if ok and board_id != truth["id"]:
                tally.wrong.append(f"read_id {board_id:#x}")


async def _truth(uno: VirtualUno, board: Board) -> dict[str, Any]:
    for pin, mv in ANALOG.items():
        await uno.set_analog(int(pin), mv)
    truth: dict[str, Any] = {pin.name: await board.analog(pin).read() for pin in ANALOG}
    truth["temperature"] = await board.temperature()
    truth["id"] = await board.read_id()
    return truth


async def soak(args: argparse.Namespace) -> dict[str, Any]:
    """The soak of single calls (``crc_link`` runs it in either framing)."""
    tally = Tally(args.commands)
    pin_tasks = min(len(OUTPUT_PINS), args.tasks - 3)

    def start_task(
        tg: anyio.abc.TaskGroup, uno: VirtualUno, board: Board, truth: Any, index: int
    ) -> None:
        if index < pin_tasks:
            tg.start_soon(pin_task, board, uno, OUTPUT_PINS[index], tally)
        else:
            tg.start_soon(reader_task, board, truth, index, tally)

    figures = await _soak.run(args, tally, _truth, start_task)
    return {
        "commands": tally.issued,
        **figures,
        "commands_per_s": round(tally.issued / figures["seconds"], 1),
        "success_rate": tally.ok / tally.issued,
        "wrong_answers": len(tally.wrong),
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
    args.timeout = None
    result = {"command": command_line(), **anyio.run(soak, args)}
    report(result, args.json)


if __name__ == "__main__":
    main()
