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

from arduinoio_async import protocol as p
from arduinoio_async.sim import SimulatorNotAvailable, find_firmware_elf, find_harness_binary
from benchmarks.peers.peers_table import goals

pytestmark = pytest.mark.sim

REPO = Path(__file__).resolve().parents[2]
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
    args = [sys.executable, "-m", "benchmarks.peers.peer_bench", "--json", str(out)]
    args += ["--doc", str(doc), "--readme", str(readme), "--n", "4", "--rounds", "1"]
    args += ["--seconds", "1", "--writes", "40", "--opens", "1"]
    run = subprocess.run(args, cwd=REPO, capture_output=True, text=True, timeout=580, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    rows = json.loads(out.read_text())["rows"]
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
        # (a) is measured four ways at the default configuration (write then read,
        # pipelined, change event, one transaction), two more behind the 16U2 with the
        # low-latency mode off (the default turns it on there); (b) likewise; (c) at
        # 1,000,000 and (not the default) 2,000,000 baud;
        # (d) from 1, 8 and 32 tasks
        opt_in = 2 if link == "16u2" else 0
        assert len(find("arduinoio", "a", link)) == 4 + opt_in
        assert len(find("arduinoio", "b", link)) == 1 + opt_in // 2
        assert {r["baud"] for r in find("arduinoio", "c", link)} == {p.DEFAULT_BAUD, p.FAST_BAUD}
        assert all("lost 0" in str(r["client"]) for r in find("arduinoio", "c", link))
        for r in rows:
            if r["system"] == "arduinoio" and r["baud"] != p.DEFAULT_BAUD:
                assert "not the default" in str(r["client"]), r
        writes = find("arduinoio", "d", link)
        assert len(writes) == 3
        assert all(r["n"] == 40 and r["p50_ms"] is None for r in writes)  # every write landed
        assert all(isinstance(r["rate_per_s"], float) for r in writes)
    firmata = [r for r in rows if r["system"] == "firmata"]
    if "Firmata rows skipped" not in run.stdout:
        assert {r["test"] for r in firmata} == set("abcde")
        assert all(r["baud"] == 57600 for r in firmata)
        raw_writes = [r for r in firmata if r["test"] == "d" and r["client"] == "raw"]
        assert [r["n"] for r in raw_writes] == [40, 40]  # no write lost on the way
        assert "The speed goals" in doc.read_text()
    else:
        assert not firmata
    text = doc.read_text()
    assert text.startswith("before\n") and text.endswith("after\n") and "old" not in text
    assert "(a) host sets D2" in text and "arduinoio_async: read ID" in text
    assert "| client (baud) |" in readme.read_text()


def _row(
    system: str, client: str, test: str, link: str, baud: int, value: float
) -> dict[str, object]:
    rate = test in "cd"
    return {
        "system": system,
        "client": client,
        "test": test,
        "link": link,
        "baud": baud,
        "n": 1,
        "p50_ms": None if rate else value,
        "rate_per_s": value if rate else None,
    }


def test_goals_judge_the_default_configuration_against_the_best_firmata_client() -> None:
    rows = [
        _row("firmata", "raw", "a", "none", 57600, 1.3),
        _row("firmata", "pyfirmata2", "a", "none", 57600, 1.6),
        _row("arduinoio", "write, then read", "a", "none", 1_000_000, 0.9),
        _row("arduinoio", "pipelined", "a", "none", 1_000_000, 0.8),
        _row("arduinoio", "faster (not the default)", "a", "none", 1_000_000, 0.1),
        _row("arduinoio", "paper rate", "a", "none", 115200, 0.05),
        _row("firmata", "raw", "d", "none", 57600, 1800.0),
        _row("firmata", "pymata_express", "d", "none", 57600, 1900.0),
        _row("arduinoio", "32 tasks", "d", "none", 1_000_000, 2800.0),
    ]
    judged = {g["test"]: g for g in goals(rows, 1_000_000)}
    # (a): lower is better; the raw floor is the best Firmata; other choices and bauds
    # do not count
    assert judged["a"]["firmata_client"] == "raw"
    assert judged["a"]["project_client"] == "pipelined"
    assert judged["a"]["factor"] == round(1.3 / 0.8, 2) and judged["a"]["met"]
    # (d): higher is better; 2800 / 1900 = 1.47 misses 1.5
    assert judged["d"]["firmata_client"] == "pymata_express"
    assert judged["d"]["factor"] == 1.47 and not judged["d"]["met"]
    assert set(judged) == {"a", "d"}
