"""Markdown tables from a recorded ``arduinoio bench --json`` file (for docs/performance.md).

.venv/bin/python -m benchmarks.tables benchmarks/results/latest.json
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
    labels = {
        "asyncio": "this library, asyncio",
        "uvloop": "this library, uvloop",
        "asyncio_minimal": "minimal asyncio client (the loop's floor)",
        "uvloop_minimal": "minimal uvloop client (the loop's floor)",
    }
    ratios = [(label, v) for v, label in labels.items() if f"{v}_ratio_iqr" in pty]
    if ratios:
        rows += [
            "",
            f"| CPU / bare pyserial, {pty['rounds']} interleaved rounds | median | IQR |",
            "|---|---|---|",
        ]
        for label, v in ratios:
            low, high = pty[f"{v}_ratio_iqr"]
            rows.append(f"| {label} | {pty[f'{v}_ratio_median']:.2f}x | {low:.2f}-{high:.2f} |")
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
