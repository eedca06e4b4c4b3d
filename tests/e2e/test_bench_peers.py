"""The peer benchmark's code paths with tiny N (``benchmarks/peers``, ``make bench-peers``).

The project's rows must always be measured.  The Firmata rows need StandardFirmata (npm)
and, for the three libraries, the peers' environment ``.venv-peers``; without them those
rows are skipped by the benchmark itself and only the project's rows are checked.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from arduinoio_async.sim import SimulatorNotAvailable, find_firmware_elf, find_harness_binary

pytestmark = pytest.mark.sim

REPO = Path(__file__).resolve().parents[2]
PEERS = REPO / "benchmarks" / "peers"
KEYS = ["system", "client", "test", "link", "baud", "n"]
KEYS += ["p50_ms", "p90_ms", "p99_ms", "mean_ms", "rate_per_s"]


@pytest.mark.timeout(600)
def test_peer_benchmark_tiny_run_writes_rows_and_renders(tmp_path: Path) -> None:
    try:
        find_harness_binary()
        find_firmware_elf(115200)
    except SimulatorNotAvailable as exc:
        pytest.skip(str(exc))
    doc, readme = tmp_path / "perf.md", tmp_path / "README.md"
    doc.write_text("before\n<!-- peers:table:begin -->\nold\n<!-- peers:table:end -->\nafter\n")
    readme.write_text("x\n<!-- peers:summary:begin -->\n<!-- peers:summary:end -->\ny\n")
    out = tmp_path / "peers.json"
    args = [sys.executable, str(PEERS / "peer_bench.py"), "--json", str(out)]
    args += ["--doc", str(doc), "--readme", str(readme), "--n", "4", "--rounds", "2"]
    args += ["--seconds", "1", "--writes", "40", "--opens", "1"]
    run = subprocess.run(args, capture_output=True, text=True, timeout=580, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    rows = json.loads(out.read_text())
    assert all(list(r) == KEYS for r in rows)

    def find(system: str, test: str, link: str) -> list[dict[str, object]]:
        return [r for r in rows if (r["system"], r["test"], r["link"]) == (system, test, link)]

    for link in ("16u2", "none"):
        for test in "abe":
            project = find("arduinoio", test, link)
            assert project, (test, link)
            for r in project:
                assert isinstance(r["p50_ms"], float) and r["p50_ms"] > 0
                assert isinstance(r["mean_ms"], float) and r["rate_per_s"] is None
        # (a) is measured four ways (write then read, pipelined, change event, one
        # transaction); (c) at 115200 and 1,000,000 baud; (d) 1 and 8 tasks
        assert len(find("arduinoio", "a", link)) == 4
        assert {r["baud"] for r in find("arduinoio", "c", link)} == {115200, 1000000}
        assert all("lost 0" in str(r["client"]) for r in find("arduinoio", "c", link))
        writes = find("arduinoio", "d", link)
        assert len(writes) == 2
        assert all(r["n"] == 40 and r["p50_ms"] is None for r in writes)  # every write landed
        assert all(isinstance(r["rate_per_s"], float) for r in writes)
    firmata = [r for r in rows if r["system"] == "firmata"]
    if "Firmata rows skipped" not in run.stdout:
        assert {r["test"] for r in firmata} == set("abcde")
        assert all(r["baud"] == 57600 for r in firmata)
        raw_writes = [r for r in firmata if r["test"] == "d" and r["client"] == "raw"]
        assert [r["n"] for r in raw_writes] == [40, 40]  # no write lost on the way
    else:
        assert not firmata
    text = doc.read_text()
    assert text.startswith("before\n") and text.endswith("after\n") and "old" not in text
    assert "(a) host sets D2" in text and "arduinoio_async: read ID" in text
    assert "| client (baud) |" in readme.read_text()
