"""CRC-16 framing against the paper's XOR byte: wrong answers on a bad line, and the cost.

Two measurements, both on virtual Unos at ``--baud`` (default 1,000,000):

* **Wrong answers** (``--soak``): the soak of ``benchmarks.soak`` (many tasks, every
  answer checked against the harness's fixture, never against the library) with
  ``--fault`` line faults (each of drop, insert and flip per board->host byte), run for
  ``--commands`` calls in CRC-16 framing and ``--xor-commands`` in XOR framing.
* **Cost** (``--cost``): ``--rounds`` rounds, each opening one board in XOR framing and one
  in CRC-16 framing (in alternating order, the same virtual Uno, so both see the same
  machine load): the median round-trip latency of ``--latency-calls`` sequential
  READ_IDs, and the throughput of pipelined GPIO WRITEs from 8 tasks for
  ``--throughput-s`` seconds.  Reported: the median over rounds of each mode, the spread
  (min-max over rounds), and the cost of CRC framing in percent of XOR's, from the
  per-round pairs (median of the per-round ratios).

Recorded, never asserted; ``--record`` read-modify-writes only the keys ``crc_wrong_1e2``,
``crc_wrong_1e2_commands``, ``crc_cost_pct`` and ``crc_link`` of
``benchmarks/results/link.json`` (other benchmarks write other keys there)::

    .venv/bin/python -m benchmarks.crc_link --soak --cost --commands 1000000 \\
        --xor-commands 1000000 --record
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D4, Board, LinkError
from arduinoio_async import protocol as p
from arduinoio_async.protocol.session import Session
from arduinoio_async.sim import VirtualUno
from arduinoio_async.transport import FRAMING_ENV

from . import soak as soak_bench
from ._results import LINK_JSON, command_line, merge_result, report


def set_framing(name: str) -> None:
    """The framing the next Board.open asks for (the transport reads the environment)."""
    os.environ[FRAMING_ENV] = name


async def run_soak(framing: str, commands: int, args: argparse.Namespace) -> dict[str, Any]:
    set_framing(framing)
    ns = argparse.Namespace(
        commands=commands,
        tasks=args.tasks,
        baud=args.baud,
        fault=args.fault,
        seed=args.seed,
        timeout=None,
    )
    result = await soak_bench.soak(ns)
    result["framing"] = framing
    return result


async def latency_and_throughput(
    uno: VirtualUno, framing: str, args: argparse.Namespace
) -> dict[str, Any]:
    set_framing(framing)
    failed = 0
    async with Board.open(uno.port, baudrate=args.baud, timeout=2.0) as board:
        assert board.link.framing.name.lower() == framing, board.link.framing
        samples = []
        for _ in range(args.latency_calls):
            start = time.perf_counter()
            try:
                await board.read_id()
            except LinkError:  # a loaded machine can starve the harness: not a sample
                failed += 1
                continue
            samples.append(time.perf_counter() - start)
        out = await board.digital_output(D4)
        done = 0
        stop_at = time.perf_counter() + args.throughput_s

        async def writer() -> None:
            nonlocal done
            level = False
            nonlocal failed
            while time.perf_counter() < stop_at:
                level = not level
                try:
                    await out.write(level)
                except LinkError:
                    failed += 1
                    continue
                done += 1

        start = time.perf_counter()
        async with anyio.create_task_group() as tg:
            for _ in range(8):
                tg.start_soon(writer)
        elapsed = time.perf_counter() - start
        await board.release(D4)
    return {
        "latency_s": statistics.median(samples),
        "writes_per_s": done / elapsed,
        "failed_calls": failed,
    }


async def firmware_cycles(
    uno: VirtualUno, framing: str, args: argparse.Namespace
) -> dict[str, Any]:
    """The firmware's own time per request (harness: last request byte in -> first reply
    byte out), simulated cycles: independent of the machine's load."""
    set_framing(framing)
    out: dict[str, Any] = {}
    async with Board.open(uno.port, baudrate=args.baud, timeout=2.0) as board:
        gpio = await board.digital_output(D4)
        for name, call in (("read_id", board.read_id), ("gpio_write", lambda: gpio.write(True))):
            await uno.firmware_cycles(clear=True)
            for _ in range(200):
                await call()
            samples = (await uno.firmware_cycles()).samples
            out[name] = statistics.median(samples) if samples else None
        await board.release(D4)
    return out


def host_cpu_us(framing: str, iterations: int) -> float:
    """Library CPU per round trip in the sans-IO core (encode the request, decode and
    match the reply), process time: what the framing costs the host, without the wire."""
    crc = framing == "crc16"
    session = Session(framing=p.Framing.CRC16 if crc else p.Framing.XOR)
    if crc:  # switch it as a link to a CRC board would be
        session.send(p.ReadCapabilities())
        session.receive_data(
            p.ReadCapabilitiesReply(1, 0, 1, int(p.Feature.CRC16), args_baud(), 128).encode()
        )
        session.receive_data(p.crc_framed(p.SetFramingReply(p.Framing.CRC16).encode()))
    assert session.framing.current is (p.Framing.CRC16 if crc else p.Framing.XOR)
    reply = p.ReadIdReply(7).encode()
    if crc:
        reply = p.crc_framed(reply)
    request = p.ReadId()
    start = time.process_time()
    for _ in range(iterations):
        session.send(request)
        if session.receive_reply(reply) is None:
            session.receive_data(reply)
    return (time.process_time() - start) / iterations * 1e6


def args_baud() -> int:
    return 1_000_000


async def run_components(args: argparse.Namespace) -> dict[str, Any]:
    """The cost by its parts, each measured where the machine's load cannot blur it."""
    cycles = {}
    async with VirtualUno(board_id=0x0045, baud=args.baud) as uno:
        for framing in ("xor", "crc16"):
            cycles[framing] = await firmware_cycles(uno, framing, args)
    host: dict[str, list[float]] = {"xor": [], "crc16": []}
    for index in range(21):
        for framing in ("xor", "crc16") if index % 2 == 0 else ("crc16", "xor"):
            host[framing].append(host_cpu_us(framing, 5000))
    byte_us = 10e6 / args.baud
    return {
        "firmware_cycles_median": cycles,
        "host_cpu_us_per_round_trip_median": {
            m: round(statistics.median(v), 3) for m, v in host.items()
        },
        "host_cpu_us_spread": {m: [round(min(v), 3), round(max(v), 3)] for m, v in host.items()},
        "wire_us_read_id_round_trip": {"xor": 8 * byte_us, "crc16": 10 * byte_us},
        "wire_us_gpio_write_each_way": {"xor": 5 * byte_us, "crc16": 6 * byte_us},
    }


async def run_cost(args: argparse.Namespace) -> dict[str, Any]:
    rounds: list[dict[str, Any]] = []
    async with VirtualUno(board_id=0x0044, baud=args.baud) as uno:
        for index in range(args.rounds):
            order = ("xor", "crc16") if index % 2 == 0 else ("crc16", "xor")
            row = {mode: await latency_and_throughput(uno, mode, args) for mode in order}
            rounds.append(row)

    def med(mode: str, key: str) -> float:
        return float(statistics.median(r[mode][key] for r in rounds))

    def spread(mode: str, key: str) -> list[float]:
        values = [r[mode][key] for r in rounds]
        return [min(values), max(values)]

    latency_pct = [100 * (r["crc16"]["latency_s"] / r["xor"]["latency_s"] - 1) for r in rounds]
    tput_pct = [100 * (1 - r["crc16"]["writes_per_s"] / r["xor"]["writes_per_s"]) for r in rounds]
    return {
        "rounds": args.rounds,
        "latency_calls": args.latency_calls,
        "throughput_s": args.throughput_s,
        "read_id_p50_us": {m: round(med(m, "latency_s") * 1e6, 1) for m in ("xor", "crc16")},
        "read_id_p50_us_spread": {
            m: [round(v * 1e6, 1) for v in spread(m, "latency_s")] for m in ("xor", "crc16")
        },
        "writes_per_s": {m: round(med(m, "writes_per_s")) for m in ("xor", "crc16")},
        "writes_per_s_spread": {
            m: [round(v) for v in spread(m, "writes_per_s")] for m in ("xor", "crc16")
        },
        "latency_cost_pct": round(statistics.median(latency_pct), 2),
        "latency_cost_pct_spread": [round(min(latency_pct), 2), round(max(latency_pct), 2)],
        "throughput_cost_pct": round(statistics.median(tput_pct), 2),
        "throughput_cost_pct_spread": [round(min(tput_pct), 2), round(max(tput_pct), 2)],
        "failed_calls": sum(r[m]["failed_calls"] for r in rounds for m in ("xor", "crc16")),
    }


async def main_async(args: argparse.Namespace) -> dict[str, Any]:
    result: dict[str, Any] = {
        "command": command_line(),
        "baud": args.baud,
        "load_at_start": os.getloadavg(),
    }
    if args.components:
        result["components"] = await run_components(args)
    if args.cost:
        result["cost"] = await run_cost(args)
    if args.soak:
        result["soak_crc16"] = await run_soak("crc16", args.commands, args)
        if args.xor_commands:
            result["soak_xor"] = await run_soak("xor", args.xor_commands, args)
    result["load_at_end"] = os.getloadavg()
    return result


def record(result: dict[str, Any]) -> None:
    """Merge this benchmark's keys into link.json (other keys stay as they are)."""

    def update(data: dict[str, Any]) -> None:
        if "soak_crc16" in result:
            data["crc_wrong_1e2"] = result["soak_crc16"]["wrong_answers"]
            data["crc_wrong_1e2_commands"] = result["soak_crc16"]["commands"]
        if "cost" in result:
            cost = result["cost"]
            data["crc_cost_pct"] = max(cost["latency_cost_pct"], cost["throughput_cost_pct"])
        data.setdefault("crc_link", {}).update(result)

    merge_result(LINK_JSON, update)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--soak", action="store_true")
    parser.add_argument("--cost", action="store_true")
    parser.add_argument("--components", action="store_true", help="firmware cycles, host CPU")
    parser.add_argument("--commands", type=int, default=1_000_000)
    parser.add_argument("--xor-commands", type=int, default=100_000)
    parser.add_argument("--tasks", type=int, default=13)
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--fault", type=float, default=1e-2)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=20)
    parser.add_argument("--latency-calls", type=int, default=500)
    parser.add_argument("--throughput-s", type=float, default=1.0)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--record-from", type=Path, help="record a result saved with --json")
    parser.add_argument("--record", action="store_true", help=f"update {LINK_JSON}")
    args = parser.parse_args()
    if args.record_from:
        record(json.loads(args.record_from.read_text()))
        return
    result = anyio.run(main_async, args)
    report(result, args.json)
    if args.record:
        record(result)


if __name__ == "__main__":
    main()
