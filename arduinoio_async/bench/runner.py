"""The benchmark scenarios.

Each scenario opens a board -- a virtual Uno started with the scenario's link settings,
or the real board the user named -- and measures the ten Table IV commands.  Latency is
measured from the call to the return of ``Board.request`` (as the paper measured its C++
calls).  In the sequential scenarios a random pause of up to one bridge tick separates
the commands, so each reply meets the 16U2's free-running tick at a random phase, as the
model assumes; back to back, the loop would lock to the tick.
"""

from __future__ import annotations

import functools
import os
import random
import time
from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field
from typing import Any

import anyio

from .. import protocol as p
from ..board import Board
from ..manager import BoardManager
from ..sim import VirtualUno
from ..transport import FRAMING_ENV, Transport, backend_options
from .clients import bare_round, library_round, minimal_round
from .commands import COMMANDS, BenchCommand, prepare
from .model import LinkModel, predict_ms
from .responder import InstantStream, pty_responder
from .stats import Summary, median, quartiles, summarize

__all__ = [
    "SCENARIO_GROUPS",
    "CommandResult",
    "ScenarioResult",
    "Target",
    "host_overhead",
    "run_scenario",
]

Progress = Callable[[str, int], None]


@dataclass
class Target:
    """Where to run: a real board (port or ID) or virtual Unos started per scenario."""

    port: str | None = None
    board_id: int | None = None
    baud: int = p.DEFAULT_BAUD

    @property
    def virtual(self) -> bool:
        return self.port is None and self.board_id is None


@dataclass
class CommandResult:
    name: str
    paper_ms: float
    latency: Summary
    samples_ms: list[float]
    firmware_cycles: float | None = None
    predicted_ms: float | None = None
    commands_per_s: float | None = None


@dataclass
class ScenarioResult:
    name: str
    description: str
    link: dict[str, Any]
    commands: list[CommandResult] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)


SCENARIOS: dict[str, dict[str, Any]] = {
    "paper": {
        "description": "115200 baud through the 16U2 bridge model, one request at a time",
        "baud": 115_200,
        "usb_bridge": "16u2",
        "pipelined": False,
    },
    "pipelined": {
        "description": "115200 baud through the 16U2 bridge model, many requests in flight",
        "baud": 115_200,
        "usb_bridge": "16u2",
        "pipelined": True,
    },
    "fast": {
        "description": "1,000,000 baud (the default), no bridge delay, one request at a time",
        "baud": 1_000_000,
        "usb_bridge": "none",
        "pipelined": False,
    },
    "fast-pipelined": {
        "description": "1,000,000 baud (the default), no bridge delay, many requests in flight",
        "baud": 1_000_000,
        "usb_bridge": "none",
        "pipelined": True,
    },
    "fastest": {
        "description": "2,000,000 baud, no bridge delay, one request at a time",
        "baud": 2_000_000,
        "usb_bridge": "none",
        "pipelined": False,
    },
    "fastest-pipelined": {
        "description": "2,000,000 baud, no bridge delay, many requests in flight",
        "baud": 2_000_000,
        "usb_bridge": "none",
        "pipelined": True,
    },
}
#: The command-line choices and the scenarios each runs, in the order they run.
SCENARIO_GROUPS: dict[str, tuple[str, ...]] = {
    "paper": ("paper",),
    "pipelined": ("pipelined",),
    "fast": ("fast", "fast-pipelined"),
    "fastest": ("fastest", "fastest-pipelined"),
    "host": ("host",),
}


def link_model(baud: int, bridge: bool, *, simulated: bool) -> LinkModel:
    """The model of the link a scenario runs on.

    The AVR's 115200 is really 117,647 baud (UBRR 16 with U2X).  simavr's UART moves 11
    bit times per byte in both directions (it counts a parity bit); a real UART 10.
    """
    avr_baud = 117_647 if baud == 115_200 else baud
    bits = 11 if simulated else 10
    return LinkModel(
        baud_to_board=avr_baud,
        baud_to_host=avr_baud,
        bits_to_board=bits,
        bits_to_host=bits,
        bridge_16u2=bridge,
    )


async def _blocking_pause(seconds: float) -> None:
    """Pause between sequential requests so the next one meets the bridge at a random phase.

    time.sleep, not anyio.sleep: the event loop's timers have 1 ms granularity (epoll),
    which would quantise the phase against the 16U2's 4.096 ms tick and its 1 ms USB
    frames.  Only for benchmarks whose loop runs nothing else between requests.
    """
    time.sleep(seconds)  # noqa: ASYNC251
    await anyio.lowlevel.checkpoint()


@contextmanager
def _paper_framing() -> Iterator[None]:
    """The links opened inside ask for the paper's XOR framing (Table IV was measured in
    it, and the wire model counts its frame sizes); ``benchmarks/crc_link.py`` measures
    what CRC-16 framing costs.  The transport reads ``FRAMING_ENV`` when it is built."""
    before = os.environ.get(FRAMING_ENV)
    os.environ[FRAMING_ENV] = "xor"
    try:
        yield
    finally:
        if before is None:
            del os.environ[FRAMING_ENV]
        else:
            os.environ[FRAMING_ENV] = before


@asynccontextmanager
async def _open(
    target: Target, scenario: dict[str, Any]
) -> AsyncIterator[tuple[Board, VirtualUno | None]]:
    with _paper_framing():
        async with _open_board(target, scenario) as opened:
            yield opened


@asynccontextmanager
async def _open_board(
    target: Target, scenario: dict[str, Any]
) -> AsyncIterator[tuple[Board, VirtualUno | None]]:
    if target.virtual:
        async with (
            VirtualUno(board_id=1, baud=scenario["baud"], usb_bridge=scenario["usb_bridge"]) as uno,
            Board.open(uno.port, baudrate=uno.baud, timeout=2.0) as board,
        ):
            yield board, uno
    elif target.port is not None:
        async with Board.open(target.port, baudrate=target.baud, timeout=2.0) as board:
            yield board, None
    else:
        assert target.board_id is not None
        async with BoardManager(baudrate=target.baud) as boards:
            yield await boards.get(target.board_id), None


async def _sequential(
    board: Board,
    command: BenchCommand,
    n: int,
    warmup: int,
    gap_ms: float,
    rnd: random.Random,
) -> list[float]:
    call = command.call(board)
    samples: list[float] = []
    for index in range(warmup + n):
        if gap_ms:
            await _blocking_pause(rnd.uniform(0, gap_ms) / 1e3)
        start = time.perf_counter_ns()
        await call()
        if index >= warmup:
            samples.append((time.perf_counter_ns() - start) / 1e6)
    return samples


async def _pipelined(
    board: Board, command: BenchCommand, n: int, workers: int
) -> tuple[list[float], float]:
    call = command.call(board)
    samples: list[float] = []
    remaining = n

    async def worker() -> None:
        nonlocal remaining
        while remaining > 0:
            remaining -= 1
            start = time.perf_counter_ns()
            await call()
            samples.append((time.perf_counter_ns() - start) / 1e6)

    begin = time.perf_counter()
    async with anyio.create_task_group() as tg:
        for _ in range(workers):
            tg.start_soon(worker)
    return samples, n / (time.perf_counter() - begin)


#: Requests per command behind a pipelined rate by default: a rate needs a run long
#: enough to average over ticks and scheduling.
PIPELINED_RATE_COUNT = 2000


async def run_scenario(
    name: str,
    target: Target,
    *,
    n: int,
    warmup: int,
    host_ms: float,
    rate_count: int = PIPELINED_RATE_COUNT,
    progress: Progress | None = None,
) -> ScenarioResult:
    """Run one scenario over all ten commands; a pipelined rate takes at least
    ``rate_count`` requests per command."""
    scenario = SCENARIOS[name]
    bridge = scenario["usb_bridge"] == "16u2" and target.virtual
    baud = scenario["baud"] if target.virtual else target.baud
    model = link_model(baud, bridge, simulated=target.virtual)
    result = ScenarioResult(
        name,
        scenario["description"] if target.virtual else f"{scenario['description']} (real board)",
        {"baud": baud, "usb_bridge": "16u2" if bridge else "none", "virtual": target.virtual},
    )
    rnd = random.Random(1)
    async with _open(target, scenario) as (board, uno):
        await prepare(board)
        for command in COMMANDS:
            cycles: float | None = None
            rate: float | None = None
            if scenario["pipelined"]:
                workers = min(max(1, p.RX_FIFO_SIZE // command.request_bytes), 32)
                await _pipelined(board, command, warmup, workers)
                samples, rate = await _pipelined(board, command, max(n, rate_count), workers)
            else:
                if uno is not None:
                    await uno.firmware_cycles(clear=True)
                gap = model.tick_ms if bridge else 0.0
                samples = await _sequential(board, command, n, warmup, gap, rnd)
                if uno is not None:
                    measured = [c for c in (await uno.firmware_cycles()).samples if c > 0]
                    cycles = median(measured) if measured else None
            predicted = None
            if cycles is not None:
                predicted = predict_ms(
                    model, command.request_bytes, command.reply_bytes, cycles, host_ms
                )
            result.commands.append(
                CommandResult(
                    command.name,
                    command.paper_ms,
                    summarize(samples),
                    samples,
                    cycles,
                    predicted,
                    rate,
                )
            )
            if progress is not None:
                progress(f"{name}: {command.name}", 1)
    return result


async def host_overhead(
    n: int, progress: Progress | None = None, *, rounds: int | None = None
) -> ScenarioResult:
    """The library's own CPU time per command, and the bare-pyserial floor on a pty
    (``rounds`` interleaved rounds, :data:`HOST_ROUNDS` by default)."""
    result = ScenarioResult(
        "host",
        "library CPU per command against an instant in-memory responder; "
        "bare pyserial write/read loop on a pseudo-terminal as the floor",
        {"baud": None, "usb_bridge": "none", "virtual": True},
    )
    stream = InstantStream()
    async with Transport(stream, name="instant") as link:
        board = await Board.from_link(link)
        for command in COMMANDS:
            call = command.call(board)
            for _ in range(100):
                await call()
            samples: list[float] = []
            cpu_start = time.process_time()
            for _ in range(n):
                start = time.perf_counter_ns()
                await call()
                samples.append((time.perf_counter_ns() - start) / 1e6)
            cpu_us = (time.process_time() - cpu_start) / n * 1e6
            entry = CommandResult(command.name, command.paper_ms, summarize(samples), samples)
            result.commands.append(entry)
            result.extra.setdefault("cpu_us_per_command", {})[command.name] = cpu_us
            if progress is not None:
                progress(f"host: {command.name}", 1)
    result.extra["pty"] = await _pty_floor(n, HOST_ROUNDS if rounds is None else rounds)
    return result


#: Interleaved rounds of the pty comparison (bare pyserial, library on asyncio, on uvloop).
HOST_ROUNDS = 100
#: Round trips per variant and round: short rounds, many of them, so a neighbour's burst
#: falls inside few rounds and the median ignores it.
HOST_ROUND_TRIPS = 500
#: Untimed round trips each client makes on its freshly opened port before a round.
PTY_WARMUP = 50


async def _pty_floor(n: int, rounds: int = HOST_ROUNDS) -> dict[str, Any]:
    """Read ID round trips on a pty to a responder process: bare pyserial vs the library.

    Method (the machine is shared and noisy, and its speed drifts by 2x within a minute):
    the variants run interleaved, ``rounds`` times each with ``n`` round trips, in an
    order that rotates every round (so none always runs first or right after another);
    each variant's cost is the CPU time of the measuring thread (``time.thread_time``:
    neither the responder process nor idle waiting counts); each round gives one ratio per
    library variant against the bare loop of the same round, and the median of those
    ratios is the figure, with its interquartile range as the spread.  A neighbour's burst
    slows every variant of the round alike and cancels in the ratio.

    The clients are the reference clients of :mod:`.clients`; two of the variants show
    what the event loop itself costs: the minimal client (a reader callback resolving
    one future per round trip, no library) on asyncio and on uvloop.  No asyncio client
    can go below that floor.
    """
    return await anyio.to_thread.run_sync(_pty_rounds, min(n, HOST_ROUND_TRIPS), rounds)


#: The library variant of the host comparison: the transport's round trip alone.
_library_link_round = functools.partial(library_round, through="link")


def _pty_rounds(n: int, rounds: int) -> dict[str, Any]:
    loops = ["asyncio"] + (["uvloop"] if backend_options()["use_uvloop"] else [])
    variants = [*loops, *(f"{loop}_minimal" for loop in loops)]
    order = ["bare", *variants]
    cpu: dict[str, list[float]] = {name: [] for name in order}
    rtts: dict[str, list[float]] = {name: [] for name in order}
    with pty_responder() as path:
        for index in range(rounds):
            shift = index % len(order)
            for variant in order[shift:] + order[:shift]:
                if variant == "bare":
                    got = bare_round(path, p.DEFAULT_BAUD, n, PTY_WARMUP)
                else:
                    got = anyio.run(
                        minimal_round if variant.endswith("_minimal") else _library_link_round,
                        path,
                        p.DEFAULT_BAUD,
                        n,
                        PTY_WARMUP,
                        backend="asyncio",
                        backend_options={"use_uvloop": variant.startswith("uvloop")},
                    )
                cpu[variant].append(got.cpu_us)
                rtts[variant] += got.rtts_us
    out: dict[str, Any] = {
        "rounds": rounds,
        "round_trips_per_round": n,
        "method": "interleaved rotating rounds; thread CPU time; median of per-round ratios",
        "bare_pyserial_rtt_us_p50": median(rtts["bare"]),
        "bare_pyserial_cpu_us": median(cpu["bare"]),
        "library_rtt_us_p50": median(rtts["asyncio"]),
        "library_cpu_us": median(cpu["asyncio"]),
    }
    for variant in variants:
        ratios = sorted(lib / bare for lib, bare in zip(cpu[variant], cpu["bare"], strict=True))
        out[f"{variant}_cpu_us"] = median(cpu[variant])
        out[f"{variant}_rtt_us_p50"] = median(rtts[variant])
        out[f"{variant}_ratio_median"] = median(ratios)
        out[f"{variant}_ratio_iqr"] = list(quartiles(ratios))
        out[f"{variant}_ratio_spread"] = [ratios[0], ratios[-1]]
        out[f"{variant}_ratios"] = ratios
    for loop in loops:
        # The library against the loop's own floor, per round: what the library adds to
        # the event loop, less sensitive than the ratio to bare pyserial to how loaded the
        # machine is (a busy neighbour slows the event loop's own code too).
        over = [lib / floor for lib, floor in zip(cpu[loop], cpu[f"{loop}_minimal"], strict=True)]
        out[f"{loop}_over_minimal_median"] = median(over)
        out[f"{loop}_over_minimal_iqr"] = list(quartiles(over))
        out[f"{loop}_over_minimal"] = over
    return out
