"""The PM QoS hold the latency benchmarks use (``arduinoio_async.bench.cpu_idle``).

The kernel's side (idle states chosen while the request is held) cannot be observed from a
test; what can: the request written is a native int32 of 0 us, it lasts exactly as long as
the file is open, and a system that refuses it is reported, never silently ignored.
"""

from __future__ import annotations

import argparse
import os
import struct
from pathlib import Path

import pytest

from arduinoio_async.bench import cli, cpu_idle
from arduinoio_async.bench.cpu_idle import DEFAULT, SHALLOW, ShallowCpuIdle


def open_fds() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


def test_hold_writes_a_zero_microsecond_request_and_release_withdraws_it(
    tmp_path: Path,
) -> None:
    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    before = open_fds()
    idle = ShallowCpuIdle(device)
    assert idle.hold() and idle.held
    assert device.read_bytes() == struct.pack("i", 0)
    assert len(open_fds() - before) == 1  # the request lives as long as this descriptor
    assert idle.hold()  # holding twice keeps the one request
    assert len(open_fds() - before) == 1
    idle.release()
    assert not idle.held and open_fds() == before
    idle.release()  # releasing twice is harmless


def test_set_switches_between_conditions(tmp_path: Path) -> None:
    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    with ShallowCpuIdle(device) as idle:
        assert idle.held
        assert idle.set(DEFAULT) == DEFAULT and not idle.held
        assert idle.set(SHALLOW) == SHALLOW and idle.held
    assert not idle.held


def test_a_refused_request_is_reported(tmp_path: Path) -> None:
    idle = ShallowCpuIdle(tmp_path / "missing")
    assert not idle.hold()
    assert idle.unavailable is not None and "missing" in idle.unavailable
    assert idle.set(SHALLOW) == DEFAULT


def test_bench_refuses_to_run_shallow_when_it_cannot_hold(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Asked for shallow idle states it cannot get, ``arduinoio bench`` stops before
    measuring (a usage error) instead of recording default-idle figures as shallow ones."""
    monkeypatch.setattr(cpu_idle, "CPU_DMA_LATENCY", tmp_path / "missing")
    with pytest.raises(SystemExit) as stopped:
        cli.main(["--cpu-idle", "shallow", "--fastest"])
    assert stopped.value.code == 2
    assert "--cpu-idle shallow" in capsys.readouterr().err


def test_the_option_offers_both_only_where_runs_interleave() -> None:
    single, interleaved = argparse.ArgumentParser(), argparse.ArgumentParser()
    cpu_idle.add_option(single)
    cpu_idle.add_option(interleaved, interleave=True)
    assert interleaved.parse_args(["--cpu-idle", "both"]).cpu_idle == "both"
    assert single.parse_args([]).cpu_idle == DEFAULT
    with pytest.raises(SystemExit):
        single.parse_args(["--cpu-idle", "both"])


def test_conditions_of_a_choice(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    monkeypatch.setattr(cpu_idle, "CPU_DMA_LATENCY", device)
    parser = argparse.ArgumentParser()
    idle, both = cpu_idle.conditions(parser, "both")
    assert both == [DEFAULT, SHALLOW] and not idle.held  # checked, then let go
    assert cpu_idle.conditions(parser, "default")[1] == [DEFAULT]
