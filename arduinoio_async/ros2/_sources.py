"""The table of what a board can publish or follow, and each entry's converter.

One row of :data:`INPUTS` / :data:`OUTPUTS` is everything the configuration and the
bridge need to know about a kind of pin: the ROS message type, which pins it may use (a
name of :data:`PIN_NEEDS`), whether its values come from the board's firmware-timed
stream, and the configuration keys only it takes.  Adding a sensor is one row plus a
converter from a plain reading (a dataclass below, no board handle) to the message's
payload, so the converters are unit-tested with CDR round trips before the sensor's
board API exists.  Rows for sensors whose board API is not yet in the library (sonar,
RC pulse inputs, the streamed IMU) are kept out of the tables until their handle is
wired; their converters are here already.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import _messages as msgs

__all__ = [
    "INPUTS",
    "OUTPUTS",
    "PIN_NEEDS",
    "EncoderSample",
    "JointReading",
    "Kind",
    "PulseReading",
    "RangeReading",
    "joint_reading",
    "pulse_payload",
    "range_payload",
]


@dataclass(frozen=True)
class Kind:
    """One ``type:`` of the configuration: its message and what it asks of the pins."""

    ros_type: str
    #: A key of :data:`PIN_NEEDS`: which pins it may take.
    pins: str
    #: Values come from the board's firmware-timed stream (``stream_ms``), stamped by
    #: the board's clock.
    streamed: bool = False
    #: Configuration keys only this kind takes (besides pin, type, topic).
    keys: frozenset[str] = frozenset()


#: Pins each need allows, and how an error names them.
PIN_NEEDS = {
    "digital": "D2-D13",
    "analog": "A0-A5",
    "servo": "D9, D10",
    "counter": "D2, D3",
    "duty": "D3, D5, D6, D9, D10",
    "i2c": "A4",
    "encoder": "D2-D13",
    "sonar": "D2-D13",
}

INPUTS: dict[str, Kind] = {
    "bool": Kind(msgs.BOOL, "digital", keys=frozenset({"pull_up"})),
    "volts": Kind(msgs.FLOAT32, "analog", keys=frozenset({"period", "scale"})),
    "battery": Kind(msgs.BATTERY_STATE, "analog", keys=frozenset({"period", "scale"})),
    "counter": Kind(msgs.INT64, "counter", keys=frozenset({"period"})),
    #: An MPU-6050: from the board's stream (an I2C register block per sample) when the
    #: board has ``stream_ms``, else polled every ``period``.
    "imu": Kind(msgs.IMU, "i2c", keys=frozenset({"period", "address", "accel_g", "gyro_dps"})),
    "encoder": Kind(
        msgs.JOINT_STATE,
        "encoder",
        streamed=True,
        keys=frozenset({"pin_b", "counts_per_rev", "mode", "joint", "period"}),
    ),
    #: An HC-SR04: ``pin`` is the trigger, ``echo`` the echo pin (the sensing image).
    "sonar": Kind(msgs.RANGE, "sonar", keys=frozenset({"echo", "period"})),
    #: An RC receiver channel (the sensing image's pulse inputs), -1..1 or NaN when lost.
    "rc": Kind(
        msgs.FLOAT32,
        "digital",
        keys=frozenset({"period", "timeout_ms", "low_us", "centre_us", "high_us"}),
    ),
}
OUTPUTS: dict[str, Kind] = {
    "bool": Kind(msgs.BOOL, "digital", keys=frozenset({"timeout", "safe"})),
    "servo": Kind(msgs.FLOAT64, "servo", keys=frozenset({"timeout", "safe"})),
    "motor": Kind(
        msgs.FLOAT64, "duty", keys=frozenset({"timeout", "safe", "direction", "direction2"})
    ),
    #: A position target: radians with ``steps_per_rev``, else steps; the board runs the
    #: move (trapezoidal profile); a command timeout stops it.
    "stepper": Kind(
        msgs.FLOAT64,
        "digital",
        keys=frozenset({"timeout", "direction", "max_speed", "acceleration", "steps_per_rev"}),
    ),
}

# ---- encoders -> sensor_msgs/JointState -------------------------------------------------


@dataclass(frozen=True)
class EncoderSample:
    """An encoder's count at a stream sample's board time (microseconds, wrapping)."""

    count: int
    board_time_us: int


@dataclass(frozen=True)
class JointReading:
    """A joint's position (rad) and velocity (rad/s)."""

    position: float
    velocity: float


def joint_reading(
    now: EncoderSample, since: EncoderSample | None, counts_per_rev: float
) -> JointReading:
    """Position from the count; velocity from the counts moved between two samples over
    the board's time between them (the board's clock, so host delays add no error).

    ``since`` is the sample of the previous publication (None: the first, velocity 0).
    """
    rad_per_count = 2 * math.pi / counts_per_rev
    velocity = 0.0
    if since is not None:
        elapsed_us = (now.board_time_us - since.board_time_us) & 0xFFFFFFFF
        moved = ((now.count - since.count + 2**31) & 0xFFFFFFFF) - 2**31
        if elapsed_us:
            velocity = moved * rad_per_count * 1e6 / elapsed_us
    return JointReading(now.count * rad_per_count, velocity)


# ---- sonar -> sensor_msgs/Range ---------------------------------------------------------


@dataclass(frozen=True)
class RangeReading:
    """An ultrasound echo's distance in metres (None: no echo within range)."""

    distance: float | None
    min_range: float = 0.02
    max_range: float = 4.0
    #: The sensor's cone in radians (an HC-SR04's is about 15 degrees).
    field_of_view: float = 0.26


def range_payload(stamp: msgs.Stamp, frame_id: str, reading: RangeReading) -> bytes:
    """A ``sensor_msgs/Range``; no echo is ``+inf`` (REP-117: nothing within max_range),
    a distance outside the sensor's span is clamped to it."""
    if reading.distance is None:
        metres = math.inf
    else:
        metres = min(max(reading.distance, reading.min_range), reading.max_range)
    return msgs.range_msg(
        stamp,
        frame_id,
        metres,
        min_range=reading.min_range,
        max_range=reading.max_range,
        field_of_view=reading.field_of_view,
    )


# ---- RC pulse input -> std_msgs/Float32 (normalised) ------------------------------------


@dataclass(frozen=True)
class PulseReading:
    """An RC receiver channel's pulse width in microseconds (None: signal lost)."""

    width_us: float | None
    min_us: float = 1000.0
    centre_us: float = 1500.0
    max_us: float = 2000.0


def pulse_payload(reading: PulseReading) -> bytes:
    """``std_msgs/Float32``: -1 at ``min_us``, 0 at ``centre_us``, +1 at ``max_us``
    (clamped); NaN when the signal is lost, so a consumer cannot mistake it for centre."""
    if reading.width_us is None:
        return msgs.float32_msg(math.nan)
    offset = reading.width_us - reading.centre_us
    span = reading.max_us - reading.centre_us if offset >= 0 else reading.centre_us - reading.min_us
    return msgs.float32_msg(max(-1.0, min(1.0, offset / span)))
