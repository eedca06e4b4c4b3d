"""Which ports the manager probes: USB IDs, explicit paths, globs, the environment."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
from serial.tools import list_ports

from arduinoio_async import manager


@dataclass
class FakePortInfo:
    device: str
    vid: int | None
    pid: int | None


def test_usb_bridges_of_unos_are_candidates(monkeypatch: pytest.MonkeyPatch) -> None:
    ports = [
        FakePortInfo("/dev/ttyACM0", 0x2341, 0x0043),  # Uno R3 (16U2)
        FakePortInfo("/dev/ttyUSB0", 0x1A86, 0x7523),  # CH340
        FakePortInfo("/dev/ttyUSB1", 0x0403, 0x6001),  # FTDI
        FakePortInfo("/dev/ttyUSB2", 0x10C4, 0xEA60),  # CP210x
        FakePortInfo("/dev/ttyUSB3", 0x067B, 0x2303),  # Prolific: not an Uno bridge
        FakePortInfo("/dev/ttyS0", None, None),  # on-board UART
    ]
    monkeypatch.setattr(list_ports, "comports", lambda: ports)
    monkeypatch.delenv(manager.ENV_PORTS, raising=False)
    assert manager.candidate_ports() == [
        "/dev/ttyACM0",
        "/dev/ttyUSB0",
        "/dev/ttyUSB1",
        "/dev/ttyUSB2",
    ]


def test_paths_globs_and_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in ("board-a", "board-b", "other"):
        (tmp_path / name).touch()
    monkeypatch.setenv(manager.ENV_PORTS, f"{tmp_path}/other,/dev/fixed-env")
    found = manager.candidate_ports(
        ["/dev/explicit", f"{tmp_path}/board-a"], [f"{tmp_path}/board-*"], usb=False
    )
    assert found == [
        "/dev/explicit",
        f"{tmp_path}/board-a",
        f"{tmp_path}/board-b",
        f"{tmp_path}/other",
        "/dev/fixed-env",
    ]
    assert manager.candidate_ports(usb=False, env=False) == []
