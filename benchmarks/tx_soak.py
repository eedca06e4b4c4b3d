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

    .venv/bin/python benchmarks/tx_soak.py --transactions 25000 --record
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

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim import VirtualUno

HANG_GUARD = 5.0
OUTPUT_PINS = [DigitalPin(n) for n in range(4, 14)]
ANALOG_MV = {0: 1000.0, 1: 2500.0, 2: 4000.0, 3: 500.0}
LINK_JSON = Path(__file__).resolve().parent / "results" / "link.json"


class Tally:
    def __init__(self, total: int) -> None:
        self.remaining = total
        self.issued = 0
        self.ok = 0
        self.errors: collections.Counter[str] = collections.Counter()
        self.wrong: list[str] = []
        self.hangs = 0

    def take(self) -> bool:
        if self.remaining <= 0:
            return False
        self.remaining -= 1
        self.issued += 1
        return True


async def run_one(
    board: Board, tally: Tally, requests: list[p.Request[Any]]
) -> list[p.Reply] | None:
    """One transaction: its item replies, or None when it raised or hung."""
    with anyio.move_on_after(HANG_GUARD) as guard:
        try:
            async with board.transaction() as tx:
                items = [tx.add(request) for request in requests]
            replies = [item.result() for item in items]
        except ArduinoIOError as exc:
            tally.errors[type(exc).__name__] += 1
            return None
        tally.ok += 1
        return replies
    assert guard.cancelled_caught
    tally.hangs += 1
    return None


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


async def soak(args: argparse.Namespace) -> dict[str, Any]:
    tally = Tally(args.transactions)
    async with (
        VirtualUno(board_id=0x0033, baud=args.baud, seed=args.seed) as uno,
        Board.open(uno.port, baudrate=args.baud, timeout=args.timeout) as board,
    ):
        for channel, mv in ANALOG_MV.items():
            await uno.set_analog(channel, mv)
        for pin in OUTPUT_PINS:
            await board.digital_output(pin)
        truth: dict[Any, p.Reply] = {}
        for request in [*(p.AnalogRead(c) for c in ANALOG_MV), p.ReadId()]:
            truth[request] = await board.request(request)
        await uno.set_faults(drop=args.fault, insert=args.fault, flip=args.fault, seed=args.seed)
        start = time.monotonic()
        load_start = os.getloadavg()[0]
        async with anyio.create_task_group() as tg:
            for index in range(args.tasks):
                if index < len(OUTPUT_PINS):
                    tg.start_soon(pin_task, board, uno, OUTPUT_PINS[index], truth, tally)
                else:
                    tg.start_soon(reader_task, board, index, truth, tally)
        elapsed = time.monotonic() - start
        faults = (await uno.status())["faults"]
        stats = board.link.stats
    total = tally.issued
    return {
        "command": "benchmarks/tx_soak.py " + " ".join(args.argv),
        "transactions": total,
        "tasks": args.tasks,
        "baud": args.baud,
        "fault_probability": args.fault,
        "timeout_s": args.timeout,
        "machine_load_1min": [round(load_start, 2), round(os.getloadavg()[0], 2)],
        "cpus": os.cpu_count(),
        "seconds": round(elapsed, 2),
        "transactions_per_s": round(total / elapsed, 1),
        "succeeded": tally.ok,
        "success_pct": round(100 * tally.ok / total, 3),
        "errors": dict(tally.errors),
        "wrong_items": len(tally.wrong),
        "wrong_examples": tally.wrong[:10],
        "hangs": tally.hangs,
        "injected": faults,
        "link_stats": stats.as_dict(),
    }


def record(result: dict[str, Any]) -> None:
    """Merge this script's keys into link.json (read, update, write: other keys stay)."""
    data = json.loads(LINK_JSON.read_text()) if LINK_JSON.exists() else {}
    data["tx_success_pct_1e3"] = result["success_pct"]
    data["tx_wrong"] = result["wrong_items"]
    data["tx_soak"] = result
    LINK_JSON.write_text(json.dumps(data, indent=2) + "\n")


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
    args.argv = sys.argv[1:]
    result = anyio.run(soak, args)
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")
    if args.record:
        if args.fault != 1e-3:
            sys.exit("--record stores the 1e-3 figures: run with --fault 1e-3")
        record(result)


if __name__ == "__main__":
    main()
