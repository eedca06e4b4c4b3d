"""``arduinoio bench``: measure, print against the paper, save JSON and a plot."""

from __future__ import annotations

import argparse
from pathlib import Path

import anyio
from rich.console import Console
from rich.progress import Progress

from ..errors import ArduinoIOError
from ..protocol import DEFAULT_BAUD
from ..sim import SimulatorNotAvailable
from . import cpu_idle
from .commands import COMMANDS
from .cpu_idle import SHALLOW
from .report import print_scenario, write_json, write_plot
from .runner import (
    HOST_ROUNDS,
    PIPELINED_RATE_COUNT,
    SCENARIO_GROUPS,
    ScenarioResult,
    Target,
    host_overhead,
    run_scenario,
)

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arduinoio bench", description="Latency benchmark against the paper's Table IV."
    )
    target = parser.add_mutually_exclusive_group()
    target.add_argument("--port", help="real board (default: a virtual Uno per scenario)")
    target.add_argument("--id", type=lambda t: int(t, 0), help="real board found by ID")
    parser.add_argument("--baud", type=int, default=DEFAULT_BAUD, help="baud rate of a real board")
    parser.add_argument("-n", "--count", type=int, default=300, help="requests per command")
    parser.add_argument(
        "--warmup", type=int, default=200, help="requests before measuring (sim and caches settle)"
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=HOST_ROUNDS,
        help="interleaved rounds of the host's pty comparison (fewer: a quicker, rougher look)",
    )
    parser.add_argument(
        "--rate-count",
        type=int,
        default=PIPELINED_RATE_COUNT,
        help="requests per command behind a pipelined rate (fewer: a quicker, rougher rate)",
    )
    parser.add_argument("--paper", action="store_true", help="115200 baud + 16U2 bridge model")
    parser.add_argument("--pipelined", action="store_true", help="16U2 model, many in flight")
    parser.add_argument("--fast", action="store_true", help="1,000,000 baud (default), no bridge")
    parser.add_argument("--fastest", action="store_true", help="2,000,000 baud, no bridge")
    parser.add_argument("--host", action="store_true", help="library CPU per command")
    parser.add_argument("--all", action="store_true", help="every scenario (the default)")
    cpu_idle.add_option(parser)
    parser.add_argument("--json", type=Path, help="write every figure to this file")
    parser.add_argument("--plot", type=Path, help="latency distribution plot (PNG)")
    return parser


async def _run(args: argparse.Namespace, console: Console) -> list[ScenarioResult]:
    chosen = [name for name in SCENARIO_GROUPS if getattr(args, name)]
    if args.all or not chosen:
        chosen = list(SCENARIO_GROUPS)
    runs = [scenario for name in chosen for scenario in SCENARIO_GROUPS[name]]
    target = Target(port=args.port, board_id=args.id, baud=args.baud)
    results: list[ScenarioResult] = []
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("benchmark", total=len(runs) * len(COMMANDS))

        def advance(label: str, steps: int) -> None:
            progress.update(task, advance=steps, description=label)

        host = None
        if "host" in runs:
            host = await host_overhead(max(args.count, 1000), advance, rounds=args.rounds)
        host_ms = 0.0
        if host is not None:
            # The host's share of a round trip: library plus the OS's pty path, measured
            # against a responder process that answers at once.
            host_ms = host.extra["pty"]["library_rtt_us_p50"] / 1000
        for name in runs:
            if name != "host":
                results.append(
                    await run_scenario(
                        name,
                        target,
                        n=args.count,
                        warmup=args.warmup,
                        host_ms=host_ms,
                        rate_count=args.rate_count,
                        progress=advance,
                    )
                )
        if host is not None:
            results.append(host)
    return results


def main(argv: list[str] | None = None, *, console: Console | None = None) -> int:
    console = console or Console()
    parser = build_parser()
    args = parser.parse_args(argv)
    idle, (condition,) = cpu_idle.conditions(parser, args.cpu_idle)
    idle.set(condition)
    try:
        results = anyio.run(_run, args, console)
    except SimulatorNotAvailable as exc:
        Console(stderr=True).print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 2
    except ArduinoIOError as exc:
        Console(stderr=True).print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 1
    finally:
        idle.release()
    if args.cpu_idle == SHALLOW:
        console.print("CPU idle states held shallow while measuring (PM QoS 0 us)")
    for scenario in results:
        print_scenario(console, scenario)
    if args.json:
        write_json(args.json, results, list(argv or []), args.cpu_idle)
        console.print(f"wrote {args.json}")
    if args.plot:
        write_plot(args.plot, results)
        console.print(f"wrote {args.plot}")
    return 0
