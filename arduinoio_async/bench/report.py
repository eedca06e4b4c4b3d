"""Presenting results: a rich table per scenario, a JSON file, a latency plot."""

from __future__ import annotations

import json
import os
import platform
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from .. import protocol as p
from .._version import __version__
from .runner import ScenarioResult
from .stats import STATS_VERSION

__all__ = ["print_scenario", "to_json", "write_json", "write_plot"]


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def print_scenario(console: Console, scenario: ScenarioResult) -> None:
    table = Table(title=f"{scenario.name}: {scenario.description}", title_justify="left")
    columns = ["command", "p50 ms", "p90 ms", "p99 ms", "mean ms", "paper ms", "mean/paper"]
    if scenario.name == "host":
        columns += ["CPU us/cmd"]
    elif any(c.commands_per_s for c in scenario.commands):
        columns += ["cmd/s"]
    else:
        columns += ["model ms", "firmware cycles (us)"]
    for column in columns:
        table.add_column(column, justify="left" if column == "command" else "right")
    cpu = scenario.extra.get("cpu_us_per_command", {})
    for c in scenario.commands:
        row = [
            c.name,
            _ms(c.latency.p50),
            _ms(c.latency.p90),
            _ms(c.latency.p99),
            _ms(c.latency.mean),
            f"{c.paper_ms:.2f}",
            f"{c.latency.mean / c.paper_ms:.2f}",
        ]
        if scenario.name == "host":
            row.append(f"{cpu.get(c.name, float('nan')):.1f}")
        elif c.commands_per_s:
            row.append(f"{c.commands_per_s:,.0f}")
        else:
            cycles = (
                "-"
                if c.firmware_cycles is None
                else (f"{c.firmware_cycles:.0f} ({c.firmware_cycles / 16:.0f})")
            )
            row += [_ms(c.predicted_ms), cycles]
        table.add_row(*row)
    console.print(table)
    pty = scenario.extra.get("pty")
    if pty:
        console.print(
            f"pty floor (Read ID round trip to a responder process): bare pyserial "
            f"{pty['bare_pyserial_rtt_us_p50']:.1f} us p50, {pty['bare_pyserial_cpu_us']:.1f} "
            f"us CPU; this library {pty['library_rtt_us_p50']:.1f} us p50, "
            f"{pty['library_cpu_us']:.1f} us CPU"
        )
        labels = {
            "asyncio": "this library on asyncio",
            "uvloop": "this library on uvloop",
            "asyncio_minimal": "minimal asyncio client (the loop's floor)",
            "uvloop_minimal": "minimal uvloop client (the loop's floor)",
        }
        for variant, label in labels.items():
            if f"{variant}_ratio_median" in pty and f"{variant}_ratio_iqr" in pty:
                low, high = pty[f"{variant}_ratio_iqr"]
                console.print(
                    f"CPU / bare pyserial, {label}: median "
                    f"{pty[f'{variant}_ratio_median']:.2f}x (IQR {low:.2f}-{high:.2f}, "
                    f"{pty['rounds']} interleaved rounds)"
                )
        for loop in ("asyncio", "uvloop"):
            if f"{loop}_over_minimal_median" in pty:
                low, high = pty[f"{loop}_over_minimal_iqr"]
                console.print(
                    f"CPU / minimal {loop} client, this library: median "
                    f"{pty[f'{loop}_over_minimal_median']:.2f}x (IQR {low:.2f}-{high:.2f})"
                )


def to_json(
    scenarios: list[ScenarioResult], argv: list[str], cpu_idle: str = "default"
) -> dict[str, Any]:
    def scenario_dict(s: ScenarioResult) -> dict[str, Any]:
        data = asdict(s)
        for command in data["commands"]:
            # Microsecond resolution is what the clocks give; more digits are noise.
            command["samples_ms"] = [round(x, 3) for x in command["samples_ms"]]
        return data

    return {
        "command": ["arduinoio", "bench", *argv],
        "stats_version": STATS_VERSION,
        "versions": {
            "arduinoio_async": __version__,
            "protocol": p.PROTOCOL_VERSION,
            "python": sys.version.split()[0],
        },
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "cpu_idle": cpu_idle,
        },
        "scenarios": [scenario_dict(s) for s in scenarios],
    }


def write_json(
    path: Path, scenarios: list[ScenarioResult], argv: list[str], cpu_idle: str = "default"
) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    # One line per command's samples instead of one per number: the file stays readable
    # in a diff and a fraction of the size.
    data = to_json(scenarios, argv, cpu_idle)
    arrays: list[str] = []
    for scenario in data["scenarios"]:
        for command in scenario["commands"]:
            arrays.append(json.dumps(command["samples_ms"]))
            command["samples_ms"] = f"@samples{len(arrays) - 1}@"
    text = json.dumps(data, indent=1)
    for index, array in enumerate(arrays):
        text = text.replace(f'"@samples{index}@"', array, 1)
    path.write_text(text + "\n")


def write_plot(path: Path, scenarios: list[ScenarioResult]) -> None:
    """Box plots of latency per command, one panel per scenario (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(scenarios), 1, figsize=(11, 3.2 * len(scenarios)), squeeze=False)
    for ax, scenario in zip(axes[:, 0], scenarios, strict=True):
        names = [c.name for c in scenario.commands]
        ax.boxplot([c.samples_ms for c in scenario.commands], showfliers=False)
        ax.set_xticks(range(1, len(names) + 1), names, rotation=20, fontsize=7)
        ax.plot(
            range(1, len(names) + 1),
            [c.paper_ms for c in scenario.commands],
            "rx",
            label="paper Table IV",
        )
        ax.set_ylabel("ms")
        ax.set_yscale("log")
        ax.set_title(f"{scenario.name}: {scenario.description}", fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
