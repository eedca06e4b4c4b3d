"""Side by side with Firmata on the same virtual Uno (issue: peer benchmark).

StandardFirmata 2.4 (57600 baud, prebuilt, fetched with npm: ``peer_firmware.py``) with
four clients - raw pyserial (the floor), pyfirmata2, pymata4, pymata-express - and this
project's firmware with its own library, on the same virtual Uno with the loopback
fixture (D2 jumpered to D3), with and without the model of the Uno's 16U2 USB bridge.
Tests (a)-(e) are described in ``firmata_clients.py`` and ``docs/performance.md``.
Sequential samples are taken in rounds that interleave the clients and links, so a busy
moment of the shared machine hits every client alike.

    make bench-peers
    = .venv/bin/python -m benchmarks.peers.peer_bench --json benchmarks/results/peers.json \
          --doc docs/performance.md --readme README.md

Firmata parts are skipped (with the reason printed) when npm or the peers' environment
``.venv-peers`` is missing; the raw client needs only the StandardFirmata ELF.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import anyio
import anyio.lowlevel

from arduinoio_async import protocol as p
from arduinoio_async.bench.stats import summarize
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import A0, A1, A2, A3, D2, D3
from arduinoio_async.sim import VirtualUno

from .._results import command_line, write_result
from .._timing import blocking_pause
from .firmata_clients import gap
from .peer_firmware import FIRMATA_BAUD, FirmataUnavailable, firmata_elf
from .peers_table import (
    NOT_DEFAULT,
    goal_table,
    goals,
    render_markdown,
    render_summary,
    replace_between,
)

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
WORKER = HERE / "firmata_clients.py"
PEER_PYTHON = REPO / ".venv-peers" / "bin" / "python"
LINKS = ("none", "16u2")
#: The project at its default configuration (the speed goals are about it) ...
PROJECT_BAUD = p.DEFAULT_BAUD
#: ... and other choices, marked NOT_DEFAULT in the client name: 2 Mbaud for (c), the
#: low-latency mode off behind the 16U2 for (a) and (b).
FAST_BAUD = p.FAST_BAUD
FIRMATA_LIBRARIES = ("pyfirmata2", "pymata4", "pymata_express")
#: (d): one task waits for each acknowledgement; concurrent tasks keep writes in flight.
WRITE_TASKS = (1, 8, 32)


@dataclass
class Sizes:
    """How much to measure; the test uses tiny values, ``make bench-peers`` the defaults."""

    n: int = 200  # sequential samples per client, link and test (a), (b)
    rounds: int = 4  # interleaving rounds for (a), (b)
    seconds: float = 20.0  # test (c)
    writes: int = 2000  # test (d)
    opens: int = 5  # test (e)


def row(
    system: str, client: str, test: str, link: str, baud: int, **figures: Any
) -> dict[str, Any]:
    base: dict[str, Any] = {"system": system, "client": client, "test": test, "link": link}
    base["baud"] = baud
    for key in ("n", "p50_ms", "p90_ms", "p99_ms", "mean_ms", "rate_per_s"):
        base[key] = figures.get(key)
    return base


def latency_figures(samples: list[float]) -> dict[str, Any]:
    """n, p50, p90, p99 and mean in ms (:mod:`arduinoio_async.bench.stats`)."""
    return summarize(samples).rounded(3, "_ms")


# ------------------------------------------------------------------ Firmata side
class FirmataRunner:
    """Runs ``firmata_clients.py`` for one client in the right interpreter."""

    def __init__(self, peer_python: Path | None) -> None:
        self.peer_python = peer_python

    def clients(self) -> list[str]:
        return ["raw", *(FIRMATA_LIBRARIES if self.peer_python else ())]

    async def run(self, client: str, test: str, port: str, **options: Any) -> dict[str, Any]:
        python = str(self.peer_python) if self.peer_python else sys.executable
        args = [python, str(WORKER), "--client", client, "--test", test, "--port", port]
        for key, value in options.items():
            args += [f"--{key}", str(value)]
        result = await anyio.run_process(args, check=False)
        out = result.stdout.decode(errors="replace")
        for line in reversed(out.splitlines()):
            if line.startswith("RESULT "):
                return dict(json.loads(line[len("RESULT ") :]))
        err = result.stderr.decode(errors="replace")[-1500:]
        raise RuntimeError(f"{client} test {test} failed ({result.returncode}): {err}")


async def firmata_booted(uno: VirtualUno) -> None:
    """Wait until StandardFirmata has finished booting: it blinks its version (~2 s) before
    it reports version and name (dropped by the harness while no host holds the port)."""
    with anyio.fail_after(20):
        while True:
            status = await uno.status()
            if status["bytes_to_host"] + status["bytes_discarded"] >= 3:
                return
            await anyio.sleep(0.05)


# ------------------------------------------------------------------ project side
async def pause() -> None:
    """The Firmata side's pause between sequential samples (``firmata_clients.gap``)."""
    await blocking_pause(gap())


AIO = "arduinoio"
A_SEQUENTIAL = "arduinoio_async: write, then read"
A_PIPELINED = "arduinoio_async: write + read pipelined"
A_EVENT = "arduinoio_async: write + change event"
A_TRANSACTION = "arduinoio_async: write + read in one transaction"
B_READ_ID = "arduinoio_async: read ID"
LOW_LATENCY_OFF = f"low-latency mode off ({NOT_DEFAULT} behind a 16U2)"


@asynccontextmanager
async def project_board(uno: VirtualUno, low_latency: bool | None = None) -> AsyncIterator[Board]:
    """The board as ``Board.open`` opens it by default, or with ``low_latency`` as said.

    By default the library turns the low-latency mode on when the port's USB IDs name an
    Uno's 16U2 bridge (``Board.choose_low_latency``).  A pseudo-terminal has no USB IDs, so
    on the virtual Uno's 16U2 model the benchmark sets what the default picks on the Uno R3
    it models; without the bridge model the default is off, as on any other bridge.
    """
    if low_latency is None:
        low_latency = uno.usb_bridge == "16u2"
    async with Board.open(uno.port, baudrate=uno.baud, low_latency=low_latency) as board:
        yield board


async def project_a(
    uno: VirtualUno, n: int, pipelined: bool, low_latency: bool | None = None
) -> list[float]:
    """D2 written, D3 read back through the jumper; the reply must show the new level."""
    samples = []
    async with project_board(uno, low_latency) as board:
        d2, d3 = board.gpio(D2), board.gpio(D3)
        level = False
        await d2.write(level)
        await d3.read()
        for _ in range(n):
            await pause()
            level = not level
            t0 = time.perf_counter()
            if pipelined:
                async with anyio.create_task_group() as tg:
                    tg.start_soon(d2.write, level)
                    await anyio.lowlevel.checkpoint()  # the write goes out first
                    state = await d3.read()
            else:
                await d2.write(level)
                state = await d3.read()
            samples.append((time.perf_counter() - t0) * 1e3)
            if state.level != level:
                raise AssertionError(f"D3 reads {state.level}, D2 was set to {level}")
    return samples


async def project_a_event(uno: VirtualUno, n: int) -> list[float]:
    """D2 written, D3 watched: the host knows D3 when the board's change event arrives
    (it is sent from the pin-change interrupt, before the write's reply)."""
    samples = []
    async with project_board(uno) as board:
        d2 = board.gpio(D2)
        level = False
        await d2.write(level)
        async with board.gpio(D3).watch() as changes:
            for _ in range(n):
                await pause()
                level = not level
                t0 = time.perf_counter()
                async with anyio.create_task_group() as tg:
                    tg.start_soon(d2.write, level)
                    change = await changes.__anext__()
                    samples.append((time.perf_counter() - t0) * 1e3)
                if change.level != level or change.pin != 3:
                    raise AssertionError(f"D3 changed to {change.level}, D2 was set to {level}")
            if changes.lost:
                raise AssertionError(f"{changes.lost} change events lost")
    return samples


async def project_a_transaction(
    uno: VirtualUno, n: int, low_latency: bool | None = None
) -> list[float]:
    """D2 written and D3 read in one TRANSACTION frame, run back to back on the board."""
    samples = []
    async with project_board(uno, low_latency) as board:
        await board.digital_output(D2)
        await board.digital_input(D3)
        level = False
        for _ in range(n):
            await pause()
            level = not level
            t0 = time.perf_counter()
            async with board.transaction() as tx:
                tx.add(p.GpioWrite(D2, level))
                read = tx.add(p.GpioRead(D3))
            samples.append((time.perf_counter() - t0) * 1e3)
            if read.result().level != level:
                raise AssertionError(f"D3 reads {read.result().level}, D2 was set to {level}")
    return samples


async def project_b(uno: VirtualUno, n: int, low_latency: bool | None = None) -> list[float]:
    samples = []
    async with project_board(uno, low_latency) as board:
        await board.read_id()
        for _ in range(n):
            await pause()
            t0 = time.perf_counter()
            await board.read_id()
            samples.append((time.perf_counter() - t0) * 1e3)
    return samples


async def project_c(uno: VirtualUno, seconds: float) -> dict[str, Any]:
    """A0-A3 streamed at the shortest period the board admits at this baud rate."""
    period_us = p.stream_min_period_us(0b1111, p.StreamFlags.NONE, uno.baud)
    received = 0
    async with (
        project_board(uno) as board,
        board.stream(analog=[A0, A1, A2, A3], period_ms=period_us / 1000) as stream,
    ):
        warm = time.monotonic() + 0.5
        async for sample in stream:
            if sample.host_time >= warm:
                break
        start = time.monotonic()
        async for _sample in stream:
            received += 1
            if time.monotonic() - start >= seconds:
                break
        elapsed = time.monotonic() - start
        gaps, dropped = stream.gaps, stream.dropped
    return {"count": received, "seconds": elapsed, "lost": gaps + dropped, "period_us": period_us}


async def project_d(uno: VirtualUno, writes: int, tasks: int) -> float:
    """``writes`` alternating writes of D2 from ``tasks`` tasks; returns the seconds taken."""
    async with project_board(uno) as board:
        d2 = board.gpio(D2)
        await d2.write(False)
        state = {"level": False, "left": writes}

        async def writer() -> None:
            while state["left"]:
                state["left"] -= 1
                state["level"] = not state["level"]
                await d2.write(bool(state["level"]))

        t0 = time.monotonic()
        async with anyio.create_task_group() as tg:
            for _ in range(tasks):
                tg.start_soon(writer)
        return time.monotonic() - t0


async def project_e(uno: VirtualUno) -> float:
    t0 = time.perf_counter()
    async with project_board(uno) as board:
        await board.gpio(D2).write(True)
        elapsed = (time.perf_counter() - t0) * 1e3
    await anyio.sleep(0.05)  # the harness sees the close before the next open
    return elapsed


async def edges_during(
    uno: VirtualUno, action: Callable[[], Awaitable[float]]
) -> tuple[int, float]:
    """Level changes the harness counted on D2 while ``action`` ran, and its seconds."""
    await uno.command("clear_pulse_stats", pin="D2")
    seconds = await action()
    stats = await uno.pulse_stats("D2")
    return stats.count + stats.falls, seconds


# ------------------------------------------------------------------ the run
class Bench:
    def __init__(self, sizes: Sizes, firmata: FirmataRunner | None, elf: Path | None) -> None:
        self.sizes = sizes
        self.firmata = firmata
        self.elf = elf
        self.rows: list[dict[str, Any]] = []
        #: per board: did the simulation keep up with the wall clock (rebases, lag)?
        self.harness: dict[str, dict[str, Any]] = {}
        self.log: Callable[[str], None] = lambda text: print(text, flush=True)

    async def boards(self, system: str, link: str, **options: Any) -> VirtualUno:
        if system == "firmata":
            assert self.elf is not None
            options.update(elf=self.elf, baud=FIRMATA_BAUD)
        else:
            options.setdefault("baud", FAST_BAUD if system == "fast" else PROJECT_BAUD)
            options.setdefault("board_id", 1)
        uno = VirtualUno(fixture="loopback", usb_bridge=link, **options)  # type: ignore[arg-type]
        await uno.start()
        for channel, mv in enumerate((1000, 2000, 3000, 4000)):
            await uno.set_analog(channel, mv)
        if system == "firmata" and not options.get("reset_on_open"):
            await firmata_booted(uno)
        return uno

    @asynccontextmanager
    async def powered(self, link: str, *systems: str) -> AsyncIterator[dict[str, VirtualUno]]:
        """Only the boards a step needs run: StandardFirmata never sleeps, and an idle one
        still costs a fifth of a core, which a shared 2-core machine cannot spare."""
        unos: dict[str, VirtualUno] = {}
        try:
            for system in systems:
                unos[system] = await self.boards(system, link)
            yield unos
            for system, uno in unos.items():
                await self.account(f"{system}/{link}/{uno.baud}", uno)
        finally:
            for uno in unos.values():
                await uno.stop()

    async def account(self, key: str, uno: VirtualUno) -> None:
        """Record whether the board kept up with the wall clock; refuse a lossy harness."""
        status = await uno.status()
        if status["lost"] != {"to_board": 0, "to_host": 0}:
            raise RuntimeError(f"harness lost bytes: {status['lost']}")
        seen = self.harness.setdefault(key, {"boards": 0, "rebases": 0, "max_lag_us": 0.0})
        seen["boards"] += 1
        seen["rebases"] += status["rebases"]
        seen["max_lag_us"] = max(seen["max_lag_us"], status["max_lag_us"])

    def firmata_clients(self) -> list[str]:
        return self.firmata.clients() if self.firmata and self.elf else []

    async def sequential(self) -> None:
        """(a) and (b): rounds that interleave clients and links."""
        s = self.sizes
        per_round = max(1, s.n // s.rounds)
        samples: dict[tuple[str, str, str], list[float]] = {}
        for r in range(s.rounds):
            for link in LINKS:
                if self.firmata_clients():
                    async with self.powered(link, "firmata") as unos:
                        for test in ("a", "b"):
                            for client in self.firmata_clients():
                                assert self.firmata is not None
                                got = await self.firmata.run(
                                    client, test, unos["firmata"].port, n=per_round
                                )
                                key = (client, test, link)
                                samples.setdefault(key, []).extend(got["samples_ms"])
                async with self.powered(link, AIO) as unos:
                    aio = unos[AIO]
                    for name, pipelined in ((A_SEQUENTIAL, False), (A_PIPELINED, True)):
                        got_ms = await project_a(aio, per_round, pipelined)
                        samples.setdefault((name, "a", link), []).extend(got_ms)
                    got_ms = await project_a_event(aio, per_round)
                    samples.setdefault((A_EVENT, "a", link), []).extend(got_ms)
                    got_ms = await project_a_transaction(aio, per_round)
                    samples.setdefault((A_TRANSACTION, "a", link), []).extend(got_ms)
                    got_ms = await project_b(aio, per_round)
                    samples.setdefault((B_READ_ID, "b", link), []).extend(got_ms)
                    if link == "16u2":  # without the mode the default picks behind a 16U2
                        got_ms = await project_a(aio, per_round, True, low_latency=False)
                        key = (f"{A_PIPELINED}, {LOW_LATENCY_OFF}", "a", link)
                        samples.setdefault(key, []).extend(got_ms)
                        got_ms = await project_a_transaction(aio, per_round, low_latency=False)
                        key = (f"{A_TRANSACTION}, {LOW_LATENCY_OFF}", "a", link)
                        samples.setdefault(key, []).extend(got_ms)
                        got_ms = await project_b(aio, per_round, low_latency=False)
                        key = (f"{B_READ_ID}, {LOW_LATENCY_OFF}", "b", link)
                        samples.setdefault(key, []).extend(got_ms)
            self.log(f"(a), (b): round {r + 1} of {s.rounds} done")
        for (client, test, link), values in samples.items():
            system = AIO if client.startswith("arduinoio") else "firmata"
            baud = PROJECT_BAUD if system == AIO else FIRMATA_BAUD
            self.rows.append(row(system, client, test, link, baud, **latency_figures(values)))

    async def analog(self) -> None:
        """(c): 4 channels at the shortest period each accepts."""
        for link in LINKS:
            if self.firmata_clients():
                async with self.powered(link, "firmata") as unos:
                    for client in self.firmata_clients():
                        assert self.firmata is not None
                        port = unos["firmata"].port
                        got = await self.firmata.run(client, "c", port, seconds=self.sizes.seconds)
                        per_channel = min(got["counts"])
                        rate = round(statistics.fmean(got["counts"]) / got["seconds"], 1)
                        figures = {"n": per_channel, "rate_per_s": rate}
                        self.rows.append(row("firmata", client, "c", link, FIRMATA_BAUD, **figures))
            for system in (AIO, "fast"):
                async with self.powered(link, system) as unos:
                    got = await project_c(unos[system], self.sizes.seconds)
                rate = round(got["count"] / got["seconds"], 1)
                client = f"arduinoio_async: stream, {got['period_us']} us, lost {got['lost']}"
                if system == "fast":
                    client += f", {FAST_BAUD:,} baud ({NOT_DEFAULT})"
                baud = FAST_BAUD if system == "fast" else PROJECT_BAUD
                self.rows.append(row(AIO, client, "c", link, baud, n=got["count"], rate_per_s=rate))
            self.log(f"(c) on link {link} done")

    async def writes(self) -> None:
        """(d): writes that reach the pin, counted by the harness as D2 level changes."""
        n = self.sizes.writes
        for link in LINKS:
            if self.firmata_clients():
                async with self.powered(link, "firmata") as unos:
                    uno = unos["firmata"]
                    for client in self.firmata_clients():
                        assert self.firmata is not None

                        async def firmata_writes(
                            client: str = client,
                            runner: FirmataRunner = self.firmata,
                            uno: VirtualUno = uno,
                        ) -> float:
                            got = await runner.run(client, "d", uno.port, n=n)
                            return float(got["seconds"])

                        edges, seconds = await edges_during(uno, firmata_writes)
                        rate = round(edges / seconds, 1)
                        self.rows.append(
                            row(
                                "firmata", client, "d", link, FIRMATA_BAUD, n=edges, rate_per_s=rate
                            )
                        )
            async with self.powered(link, AIO) as unos:
                aio = unos[AIO]
                for tasks in WRITE_TASKS:

                    async def project_writes(tasks: int = tasks, aio: VirtualUno = aio) -> float:
                        return await project_d(aio, n, tasks)

                    edges, seconds = await edges_during(aio, project_writes)
                    client = f"arduinoio_async: {tasks} task{'s' if tasks > 1 else ''}"
                    rate = round(edges / seconds, 1)
                    self.rows.append(
                        row(AIO, client, "d", link, PROJECT_BAUD, n=edges, rate_per_s=rate)
                    )
            self.log(f"(d) on link {link} done")

    async def start_up(self) -> None:
        """(e): port open -> first command, the board resetting on open."""
        for link in LINKS:
            samples: dict[str, list[float]] = {}
            unos: dict[str, VirtualUno] = {}
            try:
                if self.firmata_clients():
                    unos["firmata"] = await self.boards("firmata", link, reset_on_open=True)
                unos[AIO] = await self.boards(AIO, link, reset_on_open=True)
                for _ in range(self.sizes.opens):  # interleaved
                    for client in self.firmata_clients():
                        assert self.firmata is not None
                        got = await self.firmata.run(client, "e", unos["firmata"].port, n=1)
                        samples.setdefault(client, []).extend(got["samples_ms"])
                    got_ms = await project_e(unos[AIO])
                    samples.setdefault("arduinoio_async: Board.open + write", []).append(got_ms)
                for system, uno in unos.items():
                    await self.account(f"{system}/{link}/{uno.baud}/reset-on-open", uno)
            finally:
                for uno in unos.values():
                    await uno.stop()
            for client, values in samples.items():
                system = AIO if client.startswith("arduinoio") else "firmata"
                baud = PROJECT_BAUD if system == AIO else FIRMATA_BAUD
                self.rows.append(row(system, client, "e", link, baud, **latency_figures(values)))
            self.log(f"(e) on link {link} done")

    async def run(self, tests: str) -> None:
        if "a" in tests or "b" in tests:
            await self.sequential()
        if "c" in tests:
            await self.analog()
        if "d" in tests:
            await self.writes()
        if "e" in tests:
            await self.start_up()
        order = {t: i for i, t in enumerate("abcde")}
        self.rows.sort(key=lambda r: (order[r["test"]], r["link"], r["system"] != "firmata"))


def find_peer_python(explicit: str | None) -> Path | None:
    if explicit == "":
        return None
    path = Path(explicit) if explicit else PEER_PYTHON
    return path if path.is_file() and os.access(path, os.X_OK) else None


async def main(args: argparse.Namespace) -> int:
    sizes = Sizes(args.n, args.rounds, args.seconds, args.writes, args.opens)
    elf: Path | None = None
    try:
        elf = firmata_elf()
    except FirmataUnavailable as exc:
        print(f"Firmata rows skipped: {exc}", flush=True)
    peer_python = find_peer_python(args.peer_python)
    if elf and not peer_python:
        print(
            "pyfirmata2/pymata4/pymata-express rows skipped: no .venv-peers "
            "(make bench-peers creates it)",
            flush=True,
        )
    bench = Bench(sizes, FirmataRunner(peer_python), elf)
    started = time.time()
    await bench.run(args.tests)
    result = {
        "command": command_line(),
        "sizes": vars(sizes),
        "seconds": round(time.time() - started, 1),
        "machine": {
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
        },
        "harness": bench.harness,
        "goals": goals(bench.rows, PROJECT_BAUD),
        "rows": bench.rows,
    }
    table = render_markdown(bench.rows) + "\n" + goal_table(bench.rows, PROJECT_BAUD)
    print(table)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_result(args.json, {"command": result["command"], "rows": bench.rows})
        meta = args.json.with_name(args.json.stem + "-run.json")
        write_result(meta, {k: v for k, v in result.items() if k != "rows"})
    if args.doc:
        args.doc.write_text(replace_between(args.doc.read_text(), "table", table))
    if args.readme:
        summary = render_summary(bench.rows, PROJECT_BAUD)
        args.readme.write_text(replace_between(args.readme.read_text(), "summary", summary))
    return 0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--json", type=Path, help="write the rows here (peers.json)")
    parser.add_argument("--doc", type=Path, help="render the table into this markdown file")
    parser.add_argument("--readme", type=Path, help="render the summary into this README")
    parser.add_argument("--tests", default="abcde")
    parser.add_argument("--n", type=int, default=Sizes.n)
    parser.add_argument("--rounds", type=int, default=Sizes.rounds)
    parser.add_argument("--seconds", type=float, default=Sizes.seconds)
    parser.add_argument("--writes", type=int, default=Sizes.writes)
    parser.add_argument("--opens", type=int, default=Sizes.opens)
    parser.add_argument(
        "--peer-python", help="interpreter with the Firmata libraries ('' = none)", default=None
    )
    return parser.parse_args(argv)


if __name__ == "__main__":
    raise SystemExit(anyio.run(main, parse_args()))
