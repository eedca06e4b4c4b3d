"""Boards local programs announce (virtual Unos): a discovery source beside USB (item 13)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from arduinoio_async import _port_registry as registry
from arduinoio_async import manager


@pytest.fixture
def registry_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv(registry.ENV_REGISTRY_DIR, str(tmp_path / "registry"))
    monkeypatch.delenv(manager.ENV_PORTS, raising=False)
    monkeypatch.setattr(manager, "_usb_ports", list)
    return tmp_path / "registry"


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_registered_ports_are_candidates_while_their_program_lives(
    registry_dir: Path, tmp_path: Path
) -> None:
    port = tmp_path / "pty-1"
    port.touch()
    with registry.announce([{"port": str(port), "id": 1, "baud": 1_000_000}]):
        assert [entry.port for entry in registry.registered_ports()] == [str(port)]
        assert registry.registered_ports()[0].board_id == 1
        assert manager.candidate_ports() == [str(port)]
        assert manager.candidate_ports(registered=False) == []
    assert manager.candidate_ports() == []
    assert list(registry_dir.iterdir()) == []  # removed on exit


def test_entries_of_dead_programs_and_vanished_ports_are_ignored(
    registry_dir: Path, tmp_path: Path
) -> None:
    port = tmp_path / "pty-2"
    port.touch()
    registry_dir.mkdir(parents=True)
    stale = registry_dir / f"{dead_pid()}.json"
    stale.write_text(json.dumps({"pid": int(stale.stem), "boards": [{"port": str(port)}]}))
    gone = registry_dir / f"{os.getpid()}.json"
    gone.write_text(json.dumps({"pid": os.getpid(), "boards": [{"port": str(tmp_path / "x")}]}))
    (registry_dir / "garbage.json").write_text("{not json")
    assert registry.registered_ports() == []
    assert manager.candidate_ports() == []
    assert not stale.exists()  # a dead program's entry is cleaned up
