"""The publisher table and its converters: plain readings -> CDR payloads, read back with
rosbags (round trips), so a sensor's converter is checked before its board API exists."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Any, cast

import pytest

from arduinoio_async.ros2 import BoardClock, parse
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2._sources import (
    INPUTS,
    OUTPUTS,
    EncoderSample,
    PulseReading,
    RangeReading,
    joint_reading,
    pulse_payload,
    range_payload,
)
from arduinoio_async.ros2._stream import StreamedInputs, _Joint

STAMP = msgs.Stamp(1_700_000_000_123_456_789)


def test_every_row_names_a_message_type_with_a_rihs01_hash() -> None:
    for kind in [*INPUTS.values(), *OUTPUTS.values()]:
        assert msgs.type_hash(kind.ros_type).startswith("RIHS01_")


def test_joint_position_and_velocity_from_counts_and_board_time() -> None:
    cpr = 2048.0
    first = joint_reading(EncoderSample(1024, 5_000_000), None, cpr)
    assert first.position == pytest.approx(math.pi) and first.velocity == 0.0
    # 512 counts back in 250 ms of board time across the 32-bit wrap: -1/4 rev per 0.25 s.
    before, after = EncoderSample(100, 0xFFFFFFFF - 99_999), EncoderSample(-412, 150_000)
    reading = joint_reading(after, before, cpr)
    assert reading.position == pytest.approx(-412 * 2 * math.pi / cpr)
    assert reading.velocity == pytest.approx(-2 * math.pi)
    # The count wraps at 2**31 too: +10 counts.
    wrapped = joint_reading(EncoderSample(-(2**31) + 4, 1_000), EncoderSample(2**31 - 6, 0), 10)
    assert wrapped.velocity == pytest.approx(10 * 2 * math.pi / 10 * 1000)


def test_joint_state_round_trip() -> None:
    payload = msgs.joint_state(STAMP, ["wheel"], [1.5], [-2.25], "base")
    message = msgs.decode(msgs.JOINT_STATE, payload)
    assert payload[:4] == b"\x00\x01\x00\x00"  # CDR little-endian encapsulation
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1_700_000_000, 123_456_789)
    assert message.header.frame_id == "base" and list(message.name) == ["wheel"]
    assert list(message.position) == [1.5] and list(message.velocity) == [-2.25]
    assert len(message.effort) == 0


@pytest.mark.parametrize(
    ("distance", "expected"),
    [(1.25, 1.25), (None, math.inf), (0.001, 0.02), (9.0, 4.0)],
)
def test_range_round_trip(distance: float | None, expected: float) -> None:
    payload = range_payload(STAMP, "sonar", RangeReading(distance))
    message = msgs.decode(msgs.RANGE, payload)
    assert message.range == pytest.approx(expected)
    assert (message.min_range, message.max_range) == (pytest.approx(0.02), pytest.approx(4.0))
    assert message.radiation_type == 0 and message.header.frame_id == "sonar"
    assert message.field_of_view == pytest.approx(0.26)


@pytest.mark.parametrize(
    ("width", "expected"),
    [(1500, 0.0), (2000, 1.0), (1000, -1.0), (1750, 0.5), (1400, -0.2), (2500, 1.0), (900, -1.0)],
)
def test_rc_pulse_round_trip(width: float, expected: float) -> None:
    message = msgs.decode(msgs.FLOAT32, pulse_payload(PulseReading(width)))
    assert message.data == pytest.approx(expected, abs=1e-6)


def test_an_rc_signal_lost_is_nan_not_centre() -> None:
    assert math.isnan(msgs.decode(msgs.FLOAT32, pulse_payload(PulseReading(None))).data)


def test_an_asymmetric_rc_channel_normalises_each_side_by_its_own_span() -> None:
    reading = PulseReading(1300, min_us=1100, centre_us=1400, max_us=1900)
    assert msgs.decode(msgs.FLOAT32, pulse_payload(reading)).data == pytest.approx(-1 / 3)


def test_a_joint_publishes_on_change_and_every_period_while_it_stands() -> None:
    """StreamedInputs with synthetic stream samples (the board's clock in board_time_us):
    a message per changed count, none while it stands until ``period`` of board time."""
    config = parse(
        {
            "boards": [
                {
                    "name": "uno",
                    "id": 1,
                    "inputs": [{"pin": "D4", "pin_b": "D5", "type": "encoder", "topic": "wheel",
                                "counts_per_rev": 100, "period": 0.05}],
                }
            ]
        }
    )  # fmt: skip
    source = config.boards[0].inputs[0]
    sent: list[Any] = []
    stream = StreamedInputs(
        cast(Any, None),
        [source],
        period_ms=None,
        clock=BoardClock(),
        frame_id="uno",
        publisher=lambda s: cast(Any, s.topic),
        put=lambda publisher, payload: sent.append(msgs.decode(msgs.JOINT_STATE, payload)),
        link_lost=cast(Any, None),
    )
    stream.joints.append(_Joint(source, cast(Any, source.topic), slot=1))
    counts = [0, 0, 5, 5, 5, 5, 5, 5, 3]  # one sample every 10 ms of board time
    for index, count in enumerate(counts):
        sample = SimpleNamespace(
            host_time=time.monotonic(),
            board_time_us=1_000_000 + index * 10_000,
            analog={},
            encoders=(99, count, 0, 0),  # slot 1 is this joint's
        )
        stream.publish(sample)
    # The first sample, the move to 5, the standing joint after 50 ms, the move back to 3.
    assert [round(m.position[0] / (2 * math.pi / 100)) for m in sent] == [0, 5, 5, 3]
    rad = 2 * math.pi / 100
    assert [m.velocity[0] for m in sent] == pytest.approx(
        [0.0, 5 * rad / 0.02, 0.0, -2 * rad / 0.01]
    )
    assert all(list(m.name) == ["wheel"] and m.header.frame_id == "uno" for m in sent)
