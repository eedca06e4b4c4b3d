"""How ``arduinoio`` commands end, as a user's shell sees them: one line, a documented code.

Each test runs the real command in a subprocess (``python -m arduinoio_async``), because
what is under test is what reaches the terminal: a traceback printed by the interpreter
or an 80-column squeeze happen outside any function a test could call.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from arduinoio_async.bench import COMMANDS

pytestmark = pytest.mark.sim

COMMAND = [sys.executable, "-m", "arduinoio_async"]


def _children(pid: int) -> list[int]:
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(child) for child in (task / "children").read_text().split()]
    return found


def _wait_for_virtual_uno(process: subprocess.Popen[str], deadline_s: float) -> None:
    """Block until ``process`` has started its virtual Uno (a child running the harness)."""
    deadline = time.monotonic() + deadline_s
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        for child in _children(process.pid):
            try:
                cmdline = Path(f"/proc/{child}/cmdline").read_bytes()
            except FileNotFoundError:
                continue
            if b"virtual-uno" in cmdline:
                return
        time.sleep(0.01)  # polling /proc: the condition has no event to wait on
    pytest.fail(f"no virtual Uno under the benchmark after {deadline_s} s")


def test_ctrl_c_during_bench_prints_one_line_and_exits_130() -> None:
    process = subprocess.Popen(
        [*COMMAND, "bench", "--fast", "-n", "100000"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a shell's foreground job
    )
    try:
        _wait_for_virtual_uno(process, deadline_s=60)
        os.killpg(process.pid, signal.SIGINT)  # Ctrl-C reaches the whole foreground group
        _, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 130, stderr
    assert stderr.splitlines() == ["error: interrupted"], stderr


def test_flash_with_a_missing_avrdude_prints_one_line_and_exits_2() -> None:
    result = subprocess.run(
        [*COMMAND, "flash", "--port", "/dev/null", "--avrdude", "/nope/avrdude"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr.splitlines() == [
        "error: --avrdude /nope/avrdude: no such executable program"
    ]


def test_piped_bench_tables_are_not_squeezed_to_80_columns() -> None:
    env = {key: value for key, value in os.environ.items() if key not in ("COLUMNS", "LINES")}
    result = subprocess.run(
        [*COMMAND, "bench", "--fast", "-n", "3", "--warmup", "1"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "…" not in result.stdout  # rich's ellipsis: a cell cut short
    header = next(line for line in result.stdout.splitlines() if "p50 ms" in line)
    for column in ("command", "p99 ms", "paper ms", "mean/paper", "firmware cycles (us)"):
        assert column in header, header  # the whole header on one line
    for command in COMMANDS:
        assert any(
            line.split("│")[1:2] == [f" {command.name:<22} "] for line in result.stdout.splitlines()
        ), command.name
