"""Markdown tables from a recorded ``arduinoio bench --json`` file (for docs/performance.md).

.venv/bin/python benchmarks/tables.py benchmarks/results/latest.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any


def latency_table(scenario: dict[str, Any]) -> list[str]:
    rows = [
        f"**{scenario['name']}**: {scenario['description']}",
        "",
        "| command | paper ms | model ms | p50 ms | mean ms | p99 ms | mean/paper | "
        "firmware cycles | cmd/s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in scenario["commands"]:
        latency = c["latency"]
        model = f"{c['predicted_ms']:.2f}" if c["predicted_ms"] else "-"
        cycles = f"{c['firmware_cycles']:.0f}" if c["firmware_cycles"] else "-"
        rate = f"{c['commands_per_s']:,.0f}" if c["commands_per_s"] else "-"
        rows.append(
            f"| {c['name']} | {c['paper_ms']:.2f} | {model} | {latency['p50']:.3f} | "
            f"{latency['mean']:.3f} | {latency['p99']:.3f} | "
            f"{latency['mean'] / c['paper_ms']:.2f} | {cycles} | {rate} |"
        )
    return rows


def host_table(scenario: dict[str, Any]) -> list[str]:
    cpu = scenario["extra"]["cpu_us_per_command"]
    pty = scenario["extra"]["pty"]
    rows = [
        f"**host**: {scenario['description']}",
        "",
        "| command | library CPU us/command | p50 us |",
        "|---|---|---|",
    ]
    for c in scenario["commands"]:
        rows.append(f"| {c['name']} | {cpu[c['name']]:.1f} | {c['latency']['p50'] * 1000:.1f} |")
    rows += [
        "",
        "| Read ID on a pty, responder process | p50 round trip us | client CPU us |",
        "|---|---|---|",
        f"| bare pyserial write/read | {pty['bare_pyserial_rtt_us_p50']:.1f} | "
        f"{pty['bare_pyserial_cpu_us']:.1f} |",
        f"| this library | {pty['library_rtt_us_p50']:.1f} | {pty['library_cpu_us']:.1f} |",
    ]
    return rows


def main(path: str) -> None:
    data = json.loads(Path(path).read_text())
    print(
        f"Recorded with `{' '.join(data['command'])}` on {data['machine']['platform']}, "
        f"{data['machine']['cpus']} CPUs, Python {data['versions']['python']}.\n"
    )
    for scenario in data["scenarios"]:
        table = host_table(scenario) if scenario["name"] == "host" else latency_table(scenario)
        print("\n".join(table) + "\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "benchmarks/results/latest.json")
