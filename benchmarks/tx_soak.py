"""Transaction soak: many tasks run transactions over a faulty line; every item checked
outside the library.

A virtual Uno at ``--baud`` drops, inserts and flips board->host bytes with probability
``--fault`` each (switched on after the handshake).  ``--tasks`` tasks share one
:class:`Board` and run ``--transactions`` transactions between them:

* ten tasks own one output pin each (D4-D13): ``[GpioWrite(pin, level), AnalogRead(a),
  ReadId()]``; after a transaction that returned, the harness's pin probe (the fixture,
  not the library) must show the level written;
* the others run ``[AnalogRead(a), AnalogRead(b), ReadId()]`` (no temperature: the ADC's
  reference switch and settling around it make such a transaction 9 ms instead of 1, and
  40 tasks would then wait most of the default timeout in the queue);

and every returned item must equal what the board gave on the clean line before the
faults (analog inputs are set by the fixture and stay put).  Counted: transactions that
returned, documented library errors by class, wrong items (a returned value the fixture
contradicts: ``tx_wrong``), hangs, and the machine's load (start, end).  A call's timeout
(``--timeout``, the library's 0.5 s by default) covers its time in the queue: with 40
tasks on a loaded machine the queue alone can use it up, and a call whose deadline passes
in flight makes the link resync, which fails or retries everything in flight, so the
figure depends on the machine as much as on the line.  Recorded, never asserted; ``--record`` merges
``tx_success_pct_1e3`` and ``tx_wrong`` into ``benchmarks/results/link.json`` (only those
keys and ``tx_soak``, the details; other keys in the file are left as they are):

    .venv/bin/python -m benchmarks.tx_soak --transactions 25000 --record

The soak core (tasks, hang guard, fault injection, figures) is :mod:`benchmarks._soak`,
shared with ``benchmarks.soak``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import anyio
import anyio.abc

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim import VirtualUno

from . import _soak
from ._results import LINK_JSON, command_line, merge_result, report
from ._soak import Tally, guarded

OUTPUT_PINS = [DigitalPin(n) for n in range(4, 14)]
ANALOG_MV = {0: 1000.0, 1: 2500.0, 2: 4000.0, 3: 500.0}


async def run_one(
    board: Board, tally: Tally, requests: list[p.Request[Any]]
) -> list[p.Reply] | None:
    """One transaction: its item replies, or None when it raised or hung."""

    async def transaction() -> list[p.Reply]:
        async with board.transaction() as tx:
            items = [tx.add(request) for request in requests]
        return [item.result() for item in items]

    return (await guarded(tally, transaction))[1]


def check(
    tally: Tally, requests: list[p.Request[Any]], replies: list[p.Reply], truth: dict[Any, p.Reply]
) -> None:
    for request, reply in zip(requests, replies, strict=True):
        want = truth.get(request)
        if want is not None and reply != want:
            tally.wrong.append(f"{request!r} -> {reply!r}, fixture gives {want!r}")


async def pin_task(
    board: Board, uno: VirtualUno, pin: DigitalPin, truth: dict[Any, p.Reply], tally: Tally
) -> None:
    level = False
    step = 0
    while tally.take():
        step += 1
        level = not level
        requests: list[p.Request[Any]] = [
            p.GpioWrite(int(pin), level),
            p.AnalogRead(step % len(ANALOG_MV)),
            p.ReadId(),
        ]
        replies = await run_one(board, tally, requests)
        if replies is None:
            continue
        check(tally, requests, replies, truth)
        if replies[0] != p.GpioWriteReply(int(pin), level):
            tally.wrong.append(f"{requests[0]!r} -> {replies[0]!r}")
        seen = await uno.pin(int(pin))
        if seen.level != int(level):
            tally.wrong.append(f"D{int(pin)} written {level} but reads {seen.level}")


async def reader_task(board: Board, index: int, truth: dict[Any, p.Reply], tally: Tally) -> None:
    step = index
    while tally.take():
        step += 1
        requests: list[p.Request[Any]] = [
            p.AnalogRead(step % len(ANALOG_MV)),
            p.AnalogRead((step + 1) % len(ANALOG_MV)),
            p.ReadId(),
        ]
        replies = await run_one(board, tally, requests)
        if replies is not None:
            check(tally, requests, replies, truth)


async def _truth(uno: VirtualUno, board: Board) -> dict[Any, p.Reply]:
    for channel, mv in ANALOG_MV.items():
        await uno.set_analog(channel, mv)
    for pin in OUTPUT_PINS:
        await board.digital_output(pin)
    truth: dict[Any, p.Reply] = {}
    for request in [*(p.AnalogRead(c) for c in ANALOG_MV), p.ReadId()]:
        truth[request] = await board.request(request)
    return truth


async def soak(args: argparse.Namespace) -> dict[str, Any]:
    tally = Tally(args.transactions)

    def start_task(
        tg: anyio.abc.TaskGroup, uno: VirtualUno, board: Board, truth: Any, index: int
    ) -> None:
        if index < len(OUTPUT_PINS):
            tg.start_soon(pin_task, board, uno, OUTPUT_PINS[index], truth, tally)
        else:
            tg.start_soon(reader_task, board, index, truth, tally)

    figures = await _soak.run(args, tally, _truth, start_task)
    return {
        "transactions": tally.issued,
        "timeout_s": args.timeout,
        **figures,
        "transactions_per_s": round(tally.issued / figures["seconds"], 1),
        "success_pct": round(100 * tally.ok / tally.issued, 3),
        "wrong_items": len(tally.wrong),
    }


def record(result: dict[str, Any]) -> None:
    """Merge this script's keys into link.json (other keys stay as they are)."""

    def update(data: dict[str, Any]) -> None:
        data["tx_success_pct_1e3"] = result["success_pct"]
        data["tx_wrong"] = result["wrong_items"]
        data["tx_soak"] = result

    merge_result(LINK_JSON, update)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--transactions", type=int, default=25_000)
    parser.add_argument("--tasks", type=int, default=40)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--fault", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--timeout", type=float, default=0.5, help="per-call timeout (queueing included)"
    )
    parser.add_argument("--json", type=Path)
    parser.add_argument("--record", action="store_true", help="merge into results/link.json")
    args = parser.parse_args()
    result = {"command": command_line(), **anyio.run(soak, args)}
    report(result, args.json)
    if args.record:
        if args.fault != 1e-3:
            sys.exit("--record stores the 1e-3 figures: run with --fault 1e-3")
        record(result)


if __name__ == "__main__":
    main()
