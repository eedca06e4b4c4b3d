"""The served board under attack: the legitimate client's latency and the server's memory
under the per-client limits of ``network/_limits.py``.

One virtual Uno is served by ``arduinoio serve`` in a process of its own (loopback TCP).
A legitimate client in this process (``open_remote_board``) calls ``read_id()`` one after
another for the whole of each phase; an attacker in a third process (a bare Zenoh session,
so it competes for the server, not for this process's CPU) runs one attack per phase:

* ``baseline``: no attack;
* ``oversized``: queries whose payload is ``--oversize-mb`` MB of zeros, one after another
  (each waits for its answer, or 3 s: Zenoh drops a message over 64 KiB unanswered),
  ``--oversized`` of them;
* ``attachments``: ``--attachments`` queries, each with an attachment never seen before,
  alternating SetSession and ReadStatus (the requests whose client matters to the
  server), up to ``--window`` unanswered at once;
* ``flood``: ``--flood`` READ ID queries as fast as the attacker can send them, up to
  ``--window`` unanswered at once, all with one attachment (a runaway client);
* ``flood_anonymous``: the same without an attachment.

Recorded per phase: the legitimate client's round trips (p50, p99, max, in wall-clock
milliseconds) and the errors it got by class; the attacker's queries, answers and errors
by class; the server's resident memory (VmRSS) before and after the phase and after the
rest that follows it.  The legitimate client's round trips count successful calls; its
longest stall is the longest time between two successful replies (a failed call is
retried after 1 ms).  Every loop is bounded by a count and a deadline; loopback only.

    .venv/bin/python -m benchmarks.network_attacks --json benchmarks/results/network_attacks.json
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import socket
import sys
import threading
import time
from pathlib import Path
from typing import Any

import anyio
import anyio.abc
import zenoh
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async import protocol as p
from arduinoio_async.bench.stats import percentile
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.network import open_remote_board, zenoh_config
from arduinoio_async.network._keys import decode_fault, request_key
from arduinoio_async.sim import VirtualUno

from ._network import serve_command
from ._results import command_line, write_result

#: This module in a child process (the attacker).
SELF = [sys.executable, "-m", "benchmarks.network_attacks"]

BOARD_ID = 1
PHASES = ("baseline", "oversized", "attachments", "flood", "flood_anonymous")
#: Longest an attack may run before the bench gives up on it (seconds).
ATTACK_DEADLINE = 120.0


def free_endpoint() -> str:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


# ---- the attacker (a process of its own) -----------------------------------------------


class Outcomes:
    """Answers to the attacker's queries, counted from Zenoh's callback threads."""

    def __init__(self, window: int) -> None:
        self.lock = threading.Lock()
        self.counts: collections.Counter[str] = collections.Counter()
        self.slots = threading.Semaphore(window)
        self.done = threading.Event()
        self.pending = 0

    def sent(self) -> None:
        self.slots.acquire()
        with self.lock:
            self.pending += 1

    def on_reply(self, reply: zenoh.Reply) -> None:
        if reply.ok is not None:
            kind = "ok"
        else:
            assert reply.err is not None
            kind = decode_fault(reply.err.payload.to_bytes()).error
        with self.lock:
            self.counts[kind] += 1

    def on_done(self) -> None:
        with self.lock:
            self.pending -= 1
            if self.pending == 0:
                self.done.set()
        self.slots.release()


def attack(endpoint: str, kind: str, count: int, size_mb: float, window: int) -> None:
    """Run one attack on the board's request key and print its outcome as one JSON line."""
    session = zenoh.open(zenoh_config(connect=[endpoint]))
    key = request_key(BOARD_ID)
    outcomes = Outcomes(1 if kind == "oversized" else window)
    start = time.monotonic()
    sent = 0
    try:
        for number in range(count):
            if time.monotonic() - start > ATTACK_DEADLINE:
                break
            attachment: bytes | None = b"runaway-client"
            if kind == "oversized":
                payload = bytes(int(size_mb * 1024 * 1024))
            elif kind == "attachments":
                request: p.Request[Any] = (
                    p.SetSession(number & 0xFF) if number % 2 else p.ReadStatus()
                )
                payload = request.encode()
                attachment = f"client-{number:08d}-{os.getpid()}".encode()
            else:
                payload = p.ReadId().encode()
                if kind == "flood_anonymous":
                    attachment = None
            outcomes.sent()
            session.get(
                key,
                handler=zenoh.handlers.Callback(outcomes.on_reply, outcomes.on_done),
                payload=payload,
                attachment=attachment,
                timeout=3.0 if kind == "oversized" else 30.0,  # Zenoh may drop it unanswered
            )
            sent += 1
        with outcomes.lock:
            if outcomes.pending == 0:
                outcomes.done.set()
        outcomes.done.wait(60.0)
    finally:
        elapsed = time.monotonic() - start
        session.close()  # type: ignore[no-untyped-call]
    print(json.dumps({"sent": sent, "seconds": round(elapsed, 3), **outcomes.counts}), flush=True)


# ---- the bench ---------------------------------------------------------------------------


async def start_server(command: list[str]) -> anyio.abc.Process:
    process = await anyio.open_process(command)
    assert process.stdout is not None
    with anyio.fail_after(30):
        await BufferedByteReceiveStream(process.stdout).receive_until(b"\n", 4096)
    return process


def summary_ms(values: list[float]) -> dict[str, float | int]:
    """Count, p50, p99 (:mod:`arduinoio_async.bench.stats`) and max of seconds, in ms."""
    if not values:
        return {"count": 0}
    return {
        "count": len(values),
        "p50": round(percentile(values, 0.5) * 1e3, 3),
        "p99": round(percentile(values, 0.99) * 1e3, 3),
        "max": round(max(values) * 1e3, 3),
    }


async def run_phase(
    args: argparse.Namespace, endpoint: str, server: anyio.abc.Process, kind: str
) -> dict[str, Any]:
    counts = {
        "oversized": args.oversized,
        "attachments": args.attachments,
        "flood": args.flood,
        "flood_anonymous": args.flood,
    }
    rss_before = rss_kb(server.pid)
    rtts: list[float] = []
    stalls = [0.0]  # the longest time without a successful reply
    errors: collections.Counter[str] = collections.Counter()
    attacker_result: dict[str, Any] = {}
    async with open_remote_board(BOARD_ID, connect=[endpoint], timeout=1.0) as board:
        finished = anyio.Event()

        async def legitimate() -> None:
            deadline = anyio.current_time() + ATTACK_DEADLINE + 30
            last_ok = time.perf_counter()
            while not finished.is_set() and anyio.current_time() < deadline:
                start = time.perf_counter()
                try:
                    await board.read_id()
                except ArduinoIOError as exc:
                    errors[type(exc).__name__] += 1
                    await anyio.sleep(0.001)  # a disconnected board fails at once
                    continue
                rtts.append(time.perf_counter() - start)
                stalls[0] = max(stalls[0], time.perf_counter() - last_ok)
                last_ok = time.perf_counter()

        async with anyio.create_task_group() as tg:
            tg.start_soon(legitimate)
            if kind == "baseline":
                await anyio.sleep(args.baseline_seconds)
            else:
                command = [*SELF, "--attack", kind, "--endpoint", endpoint]
                if args.attacker_nice:  # its CPU is not the others' (as on another machine)
                    command = ["nice", "-n", str(args.attacker_nice), *command]
                command += ["--count", str(counts[kind]), "--window", str(args.window)]
                command += ["--oversize-mb", str(args.oversize_mb)]
                result = await anyio.run_process(command, check=True)
                attacker_result = json.loads(result.stdout.decode().strip().splitlines()[-1])
            finished.set()
    rss_after = rss_kb(server.pid)
    await anyio.sleep(args.rest)
    return {
        "legitimate_ms": summary_ms(rtts),
        "legitimate_longest_stall_ms": round(stalls[0] * 1e3, 1),
        "legitimate_errors": dict(errors),
        "attacker": attacker_result,
        "server_rss_kb": {"before": rss_before, "after": rss_after, "rested": rss_kb(server.pid)},
    }


async def bench(args: argparse.Namespace) -> dict[str, Any]:
    endpoint = free_endpoint()
    phases: dict[str, Any] = {}
    async with VirtualUno(board_id=BOARD_ID, baud=args.baud) as uno:
        server = await start_server(serve_command(uno.port, args.baud, endpoint))
        try:
            for kind in args.phases:
                phases[kind] = await run_phase(args, endpoint, server, kind)
                print(kind, json.dumps(phases[kind]), flush=True)
        finally:
            server.terminate()
            await server.wait()
    return {
        "command": command_line(),
        "machine": {
            "cpus": os.cpu_count(),
            "load_average": os.getloadavg(),
            "python": platform.python_version(),
        },
        "baud": args.baud,
        "attacker_nice": args.attacker_nice,
        "clock": "wall (time.perf_counter) for every latency; memory is the server's VmRSS",
        "phases": phases,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--attack", choices=PHASES[1:], help=argparse.SUPPRESS)
    parser.add_argument("--endpoint", help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--baud", type=int, default=p.DEFAULT_BAUD)
    parser.add_argument("--phases", nargs="+", choices=PHASES, default=list(PHASES))
    parser.add_argument("--baseline-seconds", type=float, default=3.0)
    parser.add_argument("--oversized", type=int, default=10, help="oversized queries")
    parser.add_argument("--oversize-mb", type=float, default=1.0)
    parser.add_argument("--attachments", type=int, default=20000, help="distinct attachments")
    parser.add_argument("--flood", type=int, default=20000, help="flood queries")
    parser.add_argument("--window", type=int, default=1000, help="attacker's unanswered queries")
    parser.add_argument("--rest", type=float, default=2.0, help="seconds after each phase")
    parser.add_argument(
        "--attacker-nice",
        type=int,
        default=0,
        help="run the attacker at this nice level: on a shared machine its CPU is then not "
        "taken from the server and the legitimate client, as with an attacker elsewhere",
    )
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.attack:
        attack(args.endpoint, args.attack, args.count, args.oversize_mb, args.window)
        return
    result = anyio.run(bench, args)
    if args.json:
        write_result(args.json, result)


if __name__ == "__main__":
    main()
