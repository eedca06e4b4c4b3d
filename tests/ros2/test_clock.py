"""The board-clock estimate: offset and drift recovered from late-only observations.

The oracle is the synthetic truth the observations were made from: a board clock 400 ppm
slow against the host, a fixed offset, transit delays of at least 200 us plus an
exponential tail (the serial line and the event loop only ever add delay), and the
32-bit microsecond counter wrapping in the middle of the run.
"""

from __future__ import annotations

import itertools
import random

import pytest

from arduinoio_async.ros2 import BoardClock

OFFSET_NS = 1_700_000_000_000_000_000
RATE = 1.0 + 400e-6  # host ns per board ns
MIN_TRANSIT_NS = 200_000


def true_host_ns(board_us: int) -> int:
    return OFFSET_NS + int(board_us * 1000 * RATE)


def test_offset_and_drift_are_recovered_across_a_wrap() -> None:
    rng = random.Random(7)
    clock = BoardClock(bucket_s=1.0, buckets=30)
    start_us = (1 << 32) - 20_000_000  # wraps 20 s into the 60 s run
    errors = []
    for step in range(6000):  # one stamped frame every 10 ms
        board_us = start_us + step * 10_000
        transit = MIN_TRANSIT_NS + int(rng.expovariate(1 / 1_000_000))
        clock.observe(board_us & 0xFFFFFFFF, true_host_ns(board_us) + transit)
        if step >= 500:  # after five seconds of observations
            errors.append(clock.to_host_ns(board_us & 0xFFFFFFFF) - true_host_ns(board_us))
    assert clock.drift_ppm == pytest.approx(400, abs=5)
    # Late by the least transit (which no estimate can see), give or take the scatter of
    # the envelope the clock reports (148-220 us late against 200 us, spread 113 us).
    assert MIN_TRANSIT_NS - clock.spread_ns <= min(errors)
    assert max(errors) <= MIN_TRANSIT_NS + clock.spread_ns
    assert clock.spread_ns < 150_000


def test_before_the_second_bucket_the_first_pair_alone_gives_the_offset() -> None:
    clock = BoardClock()
    with pytest.raises(RuntimeError, match="no stamped frame"):
        clock.to_host_ns(0)
    clock.observe(1000, 5_000_000)
    assert clock.to_host_ns(2000) == 6_000_000
    assert clock.drift_ppm == 0.0


def test_a_board_reset_is_forgotten_after_reset() -> None:
    clock = BoardClock()
    clock.observe(50_000_000, 1_000_000_000_000)
    clock.reset()
    clock.observe(1000, 2_000_000_000_000)
    assert clock.to_host_ns(1000) == 2_000_000_000_000


def test_a_board_that_reset_by_itself_starts_a_new_estimate() -> None:
    """Its clock jumps back to 0 (not a wrap): later stamps follow the new clock."""
    clock = BoardClock(bucket_s=0.25, buckets=20)
    for step in range(100):  # 10 minutes into the old boot, 10 ms apart
        board_us = 600_000_000 + step * 10_000
        clock.observe(board_us, 5_000_000_000_000 + board_us * 1000)
    reboot_host = 6_000_000_000_000
    for step in range(100):
        board_us = 1000 + step * 10_000
        clock.observe(board_us, reboot_host + board_us * 1000)
    assert clock.to_host_ns(500_000) == reboot_host + 500_000_000


def test_stamps_of_later_board_times_never_go_back_when_the_line_moves_down() -> None:
    """A new envelope point with less transit moves the fitted line down (earlier); the
    stamps of the frames that follow must still increase (ROS consumers, tf and message
    filters drop or misorder messages whose stamps go back), and then converge on the
    new line instead of staying late."""
    clock = BoardClock(bucket_s=0.25, buckets=20)
    stamps = []
    for step in range(2000):  # 1 ms apart; 5 ms of transit in the first second, then 0.2
        board_us = step * 1_000
        transit = 5_000_000 if step < 1000 else MIN_TRANSIT_NS
        clock.observe(board_us, true_host_ns(board_us) + transit)
        stamps.append(clock.to_host_ns(board_us))
    steps = [b - a for a, b in itertools.pairwise(stamps)]
    assert min(steps) > 0, [s for s in steps if s <= 0][:5]
    # Converged: the last stamp is on the new line again (late by the least transit).
    assert stamps[-1] - true_host_ns(1999 * 1_000) <= MIN_TRANSIT_NS + clock.spread_ns


def test_a_stamp_is_never_after_its_frame_was_observed() -> None:
    """A simulated board whose clock paused for 0.5 s of host time early on (a loaded
    machine): the first buckets' slope says the host runs 3x the board, and the line
    points far ahead of when frames really arrive.  A sample cannot have happened after
    the host decoded it, so no stamp may be later than its frame's observation."""
    clock = BoardClock(bucket_s=0.25, buckets=20)
    late = []
    for step in range(1500):  # 1 ms apart; a 0.5 s pause of the board at 0.3 s
        board_us = step * 1_000
        host_ns = true_host_ns(board_us) + MIN_TRANSIT_NS + (500_000_000 if step >= 300 else 0)
        clock.observe(board_us, host_ns)
        stamp = clock.to_host_ns(board_us)
        if stamp > host_ns:
            late.append((step, stamp - host_ns))
    assert not late, late[:5]
