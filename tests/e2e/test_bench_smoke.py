"""The benchmark's code paths with tiny N: every scenario and command lands in the JSON."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rich.console import Console

from arduinoio_async.bench import COMMANDS
from arduinoio_async.cli import main

pytestmark = pytest.mark.sim


def test_bench_all_scenarios_write_json_and_plot(tmp_path: Path) -> None:
    out, plot = tmp_path / "bench.json", tmp_path / "bench.png"
    console = Console(file=open(tmp_path / "out.txt", "w"), width=160)  # noqa: SIM115
    quick = ["-n", "3", "--warmup", "1", "--rounds", "2", "--rate-count", "40"]
    code = main(
        ["bench", "--all", *quick, "--json", str(out), "--plot", str(plot)],
        console=console,
    )
    assert code == 0
    data = json.loads(out.read_text())
    scenarios = {s["name"]: s for s in data["scenarios"]}
    assert set(scenarios) == {
        "paper",
        "pipelined",
        "fast",
        "fast-pipelined",
        "fastest",
        "fastest-pipelined",
        "host",
    }
    for scenario in scenarios.values():
        assert [c["name"] for c in scenario["commands"]] == [c.name for c in COMMANDS]
        assert all(c["latency"]["n"] >= 3 for c in scenario["commands"])
    assert all(c["predicted_ms"] for c in scenarios["paper"]["commands"])
    assert all(c["commands_per_s"] for c in scenarios["pipelined"]["commands"])
    assert scenarios["host"]["extra"]["pty"]["library_cpu_us"] > 0
    assert scenarios["host"]["extra"]["pty"]["rounds"] == 2
    assert data["versions"]["protocol"] == 1 and data["machine"]["cpus"]
    assert plot.stat().st_size > 10_000
    text = (tmp_path / "out.txt").read_text()
    assert "read ID" in text and "paper ms" in text
