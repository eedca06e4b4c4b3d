"""The pulse input's width-to-position scaling (pure functions; the wire is e2e's)."""

from __future__ import annotations

import pytest

from arduinoio_async.board.pulse_inputs import scale_position, scale_throttle


@pytest.mark.parametrize(
    ("width", "expected"),
    [(1000, -1.0), (1250, -0.5), (1500, 0.0), (1750, 0.5), (2000, 1.0), (900, -1.0), (2100, 1.0)],
)
def test_position_is_linear_either_side_of_the_centre_and_clamped(
    width: int, expected: float
) -> None:
    assert scale_position(width, 1000, 1500, 2000) == pytest.approx(expected)


def test_an_off_centre_stick_maps_each_side_to_its_own_end_point() -> None:
    assert scale_position(1400, 1000, 1400, 2000) == 0.0
    assert scale_position(1200, 1000, 1400, 2000) == pytest.approx(-0.5)
    assert scale_position(1700, 1000, 1400, 2000) == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("width", "expected"), [(1000, 0.0), (1500, 0.5), (2000, 1.0), (2500, 1.0)]
)
def test_throttle_runs_zero_to_one_and_clamps(width: int, expected: float) -> None:
    assert scale_throttle(width, 1000, 2000) == pytest.approx(expected)
