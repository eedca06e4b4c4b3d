"""Remote round trip against local, next to Zenoh's own get/queryable floor.

Two virtual Unos with the same firmware and baud rate: board 1 is served by
``arduinoio serve`` in a process of its own and reached over Zenoh (loopback TCP); board
2 is opened on its port by this process.  A third process is a bare Zenoh queryable that
answers every query in its callback with a reply frame: the *floor*, what a get/queryable
round trip costs with nothing of ours in it -- the same session configuration
(``zenoh_config``), the same process layout (client here, queryable in a process of its
own, loopback TCP), a query and a reply of the same sizes as ``read_id``'s frames.  The
server runs as ``arduinoio serve`` does (uvloop when installed); this process (the local
board, the remote board's client, the floor's client) runs on plain asyncio.  In rounds,
interleaved, the bench measures batches of sequential round trips of

* ``local``: ``board.read_id()`` on the local port;
* ``remote``: ``board.read_id()`` on the remote board (the same typed API);
* ``floor``: a get on the echo queryable from this event loop (a callback handler
  handing the reply to the loop, the way any asyncio program receives it);
* ``floor_blocking``: the same get from a plain thread, blocking on Zenoh's channel;
* ``floor_server_loop``: the get on a queryable that answers from its event loop (a
  thread-to-loop hop, as an asyncio server has when the loop writes the request);
* ``floor_done_callback``: the ``floor`` get with a per-query "done" callback as well
  (what the remote stream used before it watched for vanished servers once per stream:
  ``done_callback_cost_us`` is its cost, round by round);
* ``floor_held`` (a reading aid, not the goal's floor): the ``floor`` get on a queryable
  that holds each query, in Zenoh's thread, as long as the local ``read_id`` takes (the
  served board's serial round trip) before it answers; recorded is the round trip
  *minus the hold the queryable measured*.  It is Zenoh's own round trip as the served
  path meets it: both processes idle for a millisecond between query and reply, and
  threads that slept wake up slower and with colder caches than in the back-to-back
  ``floor``;
* ``floor_held_server_loop``: the same, held and answered in the queryable's event loop
  (plus that hop);

then the pipelined throughput (many concurrent tasks) of the remote and the local board.
The goal: the remote overhead ``remote - local`` within 1.5x of the floor (p50).  The
serial round trip and the client's own transport are in both ``remote`` and ``local``,
so the overhead is what serving adds: the network round trip itself (the floor) plus our
server's work around the board's link (in Zenoh's thread, which puts the request on the
link, and in its event loop, which sends the reply), and the client stream's work around
the query.  As the machine's load drifts, the ratio is taken round by round --
``(median remote - median local) / median floor`` of the round's batches -- and reported
as the median over rounds with its quartiles; each round starts with the next kind, so
no kind always runs right after another.

``--cpu-idle shallow`` holds the CPUs out of deep idle states for the whole run (a PM QoS
request, :mod:`arduinoio_async.bench.cpu_idle`; every process on the machine gets it):
the remote path has more thread hand-offs than the floor, and on this VM a halted CPU
takes ~70 us to wake, so it shows how much of the ratio is the idle states'.

    .venv/bin/python -m benchmarks.network_bench --json benchmarks/results/network.json
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import socket
import sys
import time
from collections.abc import Awaitable, Callable
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import anyio.abc
import zenoh
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async import protocol as p
from arduinoio_async.bench import cpu_idle
from arduinoio_async.bench.stats import median, quartiles, summarize
from arduinoio_async.board import Board
from arduinoio_async.network import open_remote_board, zenoh_config
from arduinoio_async.network._keys import undeclare
from arduinoio_async.network._loop import LoopHandle, zenoh_callback
from arduinoio_async.sim import VirtualUno
from arduinoio_async.transport import run

from ._network import serve_command
from ._results import command_line, write_result

#: This module in a child process (the echo queryable).
SELF = [sys.executable, "-m", "benchmarks.network_bench"]

ECHO_KEY = "arduinoio/bench/echo"
ECHO_LOOP_KEY = "arduinoio/bench/echo_loop"
ECHO_HELD_KEY = "arduinoio/bench/echo_held"
ECHO_HELD_LOOP_KEY = "arduinoio/bench/echo_held_loop"
#: The floor's query and reply carry frames of the sizes the measured call sends and gets.
QUERY = p.ReadId().encode()
REPLY = p.ReadIdReply(0x0001).encode()


def free_endpoint() -> str:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


async def run_echo(endpoint: str) -> None:
    """The floor's peer: ``echo`` answers in Zenoh's thread, nothing else; ``echo_loop``
    answers from this process's event loop (one thread-to-loop hop, as a server has);
    ``echo_held`` (in Zenoh's thread) and ``echo_held_loop`` (from the loop) answer after
    holding the query for the microseconds its attachment asks, and attach the
    microseconds they held it."""
    session = zenoh.open(zenoh_config(listen=[endpoint]))
    loop = asyncio.get_running_loop()

    def answer(query: zenoh.Query) -> None:
        with query:
            query.reply(query.key_expr, REPLY)

    def asked_hold(query: zenoh.Query) -> float:
        attachment = query.attachment
        return int.from_bytes(attachment.to_bytes() if attachment else b"", "little") / 1e6

    def answer_held(query: zenoh.Query, arrived: float) -> None:
        held_us = round((time.perf_counter() - arrived) * 1e6)
        with query:
            query.reply(query.key_expr, REPLY, attachment=held_us.to_bytes(4, "little"))

    def hold_here(query: zenoh.Query) -> None:
        arrived = time.perf_counter()
        time.sleep(asked_hold(query))  # blocks Zenoh's thread: queries come one at a time
        answer_held(query, arrived)

    def hold_in_loop(query: zenoh.Query) -> None:
        loop.call_later(asked_hold(query), answer_held, query, time.perf_counter())

    direct = session.declare_queryable(ECHO_KEY, zenoh_callback(answer))
    looped = session.declare_queryable(ECHO_LOOP_KEY, LoopHandle().forward(answer))
    held = session.declare_queryable(ECHO_HELD_KEY, zenoh_callback(hold_here))
    held_looped = session.declare_queryable(ECHO_HELD_LOOP_KEY, LoopHandle().forward(hold_in_loop))
    print("ready", flush=True)
    await anyio.to_thread.run_sync(sys.stdin.read)  # until the bench closes our stdin
    for entity in (direct, looped, held, held_looped):
        undeclare(entity)
    session.close()  # type: ignore[no-untyped-call]


async def start(command: list[str]) -> tuple[anyio.abc.Process, bytes]:
    process = await anyio.open_process(command)
    assert process.stdout is not None
    with anyio.fail_after(30):
        line = await BufferedByteReceiveStream(process.stdout).receive_until(b"\n", 4096)
    return process, line


async def batch(call: Callable[[], Awaitable[object]], count: int) -> list[float]:
    samples = []
    for _ in range(count):
        begin = time.perf_counter()
        await call()
        samples.append((time.perf_counter() - begin) * 1000)
    return samples


async def held_batch(call: Callable[[], Awaitable[float]], count: int) -> list[float]:
    """Round trips minus the time the far end held each query (ms)."""
    samples = []
    for _ in range(count):
        begin = time.perf_counter()
        held = await call()
        samples.append((time.perf_counter() - begin - held) * 1000)
    return samples


def blocking_batch(querier: zenoh.Querier, count: int) -> list[float]:
    samples = []
    for _ in range(count):
        begin = time.perf_counter()
        for reply in querier.get(payload=QUERY):
            assert reply.ok is not None
        samples.append((time.perf_counter() - begin) * 1000)
    return samples


async def throughput(board: Board, seconds: float, tasks: int) -> float:
    done = 0
    end = anyio.current_time() + seconds

    async def worker() -> None:
        nonlocal done
        while anyio.current_time() < end:
            await board.read_id()
            done += 1

    begin = anyio.current_time()
    async with anyio.create_task_group() as tg:
        for _ in range(tasks):
            tg.start_soon(worker)
    return done / (anyio.current_time() - begin)


async def bench(args: argparse.Namespace) -> dict[str, Any]:
    serve_ep, echo_ep = free_endpoint(), free_endpoint()
    async with (
        VirtualUno(board_id=1, baud=args.baud) as served,
        VirtualUno(board_id=2, baud=args.baud) as local_uno,
    ):
        server, _ = await start(serve_command(served.port, args.baud, serve_ep))
        echo_loop = ["--uvloop"] if args.uvloop else []
        echo, _ = await start([*SELF, "--echo", echo_ep, *echo_loop])
        try:
            session = await anyio.to_thread.run_sync(
                zenoh.open, zenoh_config(connect=[serve_ep, echo_ep])
            )
            loop = LoopHandle()
            querier = session.declare_querier(ECHO_KEY, consolidation=zenoh.ConsolidationMode.NONE)

            looped_querier = session.declare_querier(
                ECHO_LOOP_KEY, consolidation=zenoh.ConsolidationMode.NONE
            )
            held_querier = session.declare_querier(
                ECHO_HELD_KEY, consolidation=zenoh.ConsolidationMode.NONE
            )
            held_looped_querier = session.declare_querier(
                ECHO_HELD_LOOP_KEY, consolidation=zenoh.ConsolidationMode.NONE
            )
            hold = zenoh.ZBytes(b"")  # set after the warm-up: the local round trip

            async def get(on: zenoh.Querier, *, done: bool = False, held: bool = False) -> float:
                """One round trip; the time the far end held the query (s) if ``held``."""
                arrived = anyio.Event()
                got: list[bytes] = []
                held_us: list[int] = []

                def on_reply(reply: zenoh.Reply) -> None:
                    assert reply.ok is not None
                    got.append(reply.ok.payload.to_bytes())
                    if reply.ok.attachment is not None:
                        held_us.append(int.from_bytes(reply.ok.attachment.to_bytes(), "little"))
                    arrived.set()

                if done:  # a per-query "done" callback as well (run when the query ends)
                    handler = zenoh_callback(partial(loop.call_soon, on_reply), lambda: None)
                else:
                    handler = loop.forward(on_reply)
                if held:
                    on.get(handler, payload=QUERY, attachment=hold)
                else:
                    on.get(handler, payload=QUERY)
                await arrived.wait()
                assert got == [REPLY]
                return held_us[0] / 1e6 if held else 0.0

            floor = partial(get, querier)
            floor_looped = partial(get, looped_querier)
            floor_done = partial(get, querier, done=True)
            floor_held = partial(get, held_querier, held=True)
            floor_held_looped = partial(get, held_looped_querier, held=True)

            samples: dict[str, list[float]] = {
                "local": [],
                "remote": [],
                "floor": [],
                "floor_blocking": [],
                "floor_server_loop": [],
                "floor_done_callback": [],
                "floor_held": [],
                "floor_held_server_loop": [],
            }
            async with (
                Board.open(local_uno.port, baudrate=args.baud) as local,
                open_remote_board(1, session=session) as remote,
            ):
                for _kind, call in (
                    ("local", local.read_id),
                    ("remote", remote.read_id),
                    ("floor", floor),
                ):
                    await batch(call, 20)  # warm-up
                # The held floor's queries wait as long as the local call takes.
                hold_us = round(median(await batch(local.read_id, 20)) * 1000)
                hold = zenoh.ZBytes(hold_us.to_bytes(4, "little"))
                await held_batch(floor_held, 20)
                await held_batch(floor_held_looped, 20)
                measures: list[tuple[str, Callable[[], Awaitable[list[float]]]]] = [
                    ("local", partial(batch, local.read_id, args.batch)),
                    ("remote", partial(batch, remote.read_id, args.batch)),
                    ("floor", partial(batch, floor, args.batch)),
                    ("floor_server_loop", partial(batch, floor_looped, args.batch)),
                    ("floor_done_callback", partial(batch, floor_done, args.batch)),
                    ("floor_held", partial(held_batch, floor_held, args.batch)),
                    (
                        "floor_held_server_loop",
                        partial(held_batch, floor_held_looped, args.batch),
                    ),
                    (
                        "floor_blocking",
                        partial(anyio.to_thread.run_sync, blocking_batch, querier, args.batch),
                    ),
                ]
                for round_index in range(args.rounds):
                    # Each round starts with the next kind: no kind always follows another.
                    shift = round_index % len(measures)
                    for kind, measure in measures[shift:] + measures[:shift]:
                        samples[kind] += await measure()
                rates: dict[str, list[float]] = {"local": [], "remote": []}
                for _ in range(3):
                    rates["local"].append(await throughput(local, args.seconds, args.tasks))
                    rates["remote"].append(await throughput(remote, args.seconds, args.tasks))
            undeclare(querier)
            undeclare(looped_querier)
            undeclare(held_querier)
            undeclare(held_looped_querier)
            await anyio.to_thread.run_sync(session.close)
        finally:
            for process in (server, echo):
                if process is echo and process.stdin is not None:
                    await process.stdin.aclose()
                process.terminate()
                await process.wait()
    return {
        "command": command_line(),
        "machine": f"{platform.machine()} {os.cpu_count()} cpus, {platform.python_version()}",
        "zenoh": zenoh.__version__ if hasattr(zenoh, "__version__") else "1.x",
        "baud": args.baud,
        "cpu_idle": args.cpu_idle,
        "floor_held_hold_us": hold_us,
        "client_loop": "uvloop" if args.uvloop else "asyncio",
        "rounds": args.rounds,
        "batch": args.batch,
        **figures(samples, args.batch),
        "pipelined_requests_per_s": {
            kind: {"median": median(v), "runs": [round(x, 1) for x in v]}
            for kind, v in rates.items()
        },
        "pipelined_tasks": args.tasks,
        "samples_ms": {k: [round(x, 4) for x in v] for k, v in samples.items()},
    }


def figures(samples: dict[str, list[float]], batch: int) -> dict[str, Any]:
    """The round-trip figures from the samples of every kind (``batch`` a round, in
    order): also how :mod:`benchmarks.rederive` recomputes a stored result's figures."""
    summary = {kind: summarize(values).as_dict() for kind, values in samples.items()}
    # The machine's load drifts: each round's medians are compared within the round.
    per_round = {
        kind: [median(values[i : i + batch]) for i in range(0, len(values), batch)]
        for kind, values in samples.items()
    }
    ratios = {
        floor: [
            (remote - local) / low
            for remote, local, low in zip(
                per_round["remote"], per_round["local"], per_round[floor], strict=True
            )
        ]
        for floor in (
            "floor",
            "floor_server_loop",
            "floor_blocking",
            "floor_held",
            "floor_held_server_loop",
        )
        if floor in per_round
    }
    overhead = {q: summary["remote"][q] - summary["local"][q] for q in ("p50", "p90", "p99")}
    done_cost = [
        (with_done - plain) * 1000
        for with_done, plain in zip(
            per_round.get("floor_done_callback", []), per_round["floor"], strict=False
        )
    ]
    out: dict[str, Any] = {
        "round_trip_ms": summary,
        "remote_overhead_ms": overhead,
        "overhead_over_floor_per_round": {
            floor: {
                "median": round(median(values), 3),
                "quartiles": [round(q, 3) for q in quartiles(values)],
            }
            for floor, values in ratios.items()
        },
        "goal": "overhead (remote p50 - local p50, per round) <= 1.5 x floor p50 (per round)",
        "goal_met_median_round": median(ratios["floor"]) <= 1.5,
    }
    if done_cost:
        out["done_callback_cost_us"] = {
            "median": round(median(done_cost), 1),
            "quartiles": [round(q, 1) for q in quartiles(done_cost)],
        }
    for name, floor in (
        ("overhead_over_floor_p50", "floor"),
        ("overhead_over_blocking_floor_p50", "floor_blocking"),
        ("overhead_over_server_loop_floor_p50", "floor_server_loop"),
    ):
        if floor in summary:
            out[name] = overhead["p50"] / summary[floor]["p50"]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--echo", metavar="ENDPOINT", help=argparse.SUPPRESS)
    parser.add_argument("--baud", type=int, default=p.DEFAULT_BAUD)
    parser.add_argument("--rounds", type=int, default=20)
    parser.add_argument("--batch", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=2.0, help="per throughput run")
    parser.add_argument("--tasks", type=int, default=16, help="concurrent tasks (pipelining)")
    parser.add_argument(
        "--uvloop",
        action="store_true",
        help="run this process and the floor's queryable on uvloop too (default: asyncio)",
    )
    cpu_idle.add_option(parser)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.echo:
        run(run_echo, args.echo, uvloop=args.uvloop)
        return
    idle, (condition,) = cpu_idle.conditions(parser, args.cpu_idle)
    idle.set(condition)
    try:
        result = run(bench, args, uvloop=args.uvloop)
    finally:
        idle.release()
    shown = {k: v for k, v in result.items() if k != "samples_ms"}
    print(json.dumps(shown, indent=2))
    if args.json:
        write_result(args.json, result, indent=None)


if __name__ == "__main__":
    main()
