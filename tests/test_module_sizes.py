"""Modules of one idea stay small: every package module under 500 lines, every firmware,
harness and firmware-test C file under 600 (the limits the project set itself).

A module that grows past its limit is a sign it holds two ideas; split it (as
``hal_avr.c`` gave its PWM timers to ``hal_avr_pwm.c``) rather than raise the limit.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE_LIMIT = 500
FIRMWARE_LIMIT = 600


def _lines(path: Path) -> int:
    return len(path.read_text().splitlines())


@pytest.mark.parametrize(
    ("pattern", "limit"),
    [
        ("arduinoio_async/**/*.py", PACKAGE_LIMIT),
        ("firmware/src/*.[ch]", FIRMWARE_LIMIT),
        ("firmware/sim/*.[ch]", FIRMWARE_LIMIT),
        ("firmware/tests/*.c", FIRMWARE_LIMIT),
    ],
)
def test_every_module_is_within_its_size(pattern: str, limit: int) -> None:
    files = [path for path in REPO.glob(pattern) if "node_modules" not in path.parts]
    assert files, pattern
    over = {str(path.relative_to(REPO)): _lines(path) for path in files if _lines(path) >= limit}
    assert not over, f"over {limit} lines (split by idea): {over}"
