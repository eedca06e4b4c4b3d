"""The standard ROS 2 messages the bridge speaks, in CDR, through ``rosbags``.

``rosbags`` (PyPI) carries the message definitions of ROS 2 Jazzy (its ``ROS2_JAZZY``
type store), serializes and deserializes CDR with the 4-byte encapsulation header that
rmw_zenoh puts in front of every payload (``00 01 00 00``, little-endian CDR), and
computes each type's RIHS01 hash, which is part of every key expression: a hash that
differed from the ROS side's would route nothing.  Nothing here writes CDR by hand.

The builders take plain Python values and return the payload bytes; :func:`decode`
gives a message object whose fields read like the ROS message's.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

__all__ = [
    "BOOL",
    "DIAGNOSTIC_ARRAY",
    "FLOAT32",
    "FLOAT64",
    "IMU",
    "INT64",
    "JOINT_STATE",
    "RANGE",
    "Stamp",
    "battery_state",
    "bool_msg",
    "decode",
    "diagnostic_array",
    "float32_msg",
    "float64_msg",
    "imu",
    "int64_msg",
    "joint_state",
    "range_msg",
    "type_hash",
]

BOOL = "std_msgs/msg/Bool"
FLOAT32 = "std_msgs/msg/Float32"
FLOAT64 = "std_msgs/msg/Float64"
INT64 = "std_msgs/msg/Int64"
IMU = "sensor_msgs/msg/Imu"
RANGE = "sensor_msgs/msg/Range"
JOINT_STATE = "sensor_msgs/msg/JointState"
BATTERY_STATE = "sensor_msgs/msg/BatteryState"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"

#: diagnostic_msgs/DiagnosticStatus levels.
DIAG_OK, DIAG_WARN, DIAG_ERROR, DIAG_STALE = 0, 1, 2, 3


@functools.cache
def _store() -> Any:
    """The Jazzy type store (built once; building it parses every definition)."""
    return get_typestore(Stores.ROS2_JAZZY)


def _new(ros_type: str, **fields: Any) -> Any:
    return _store().types[ros_type](**fields)


def _encode(message: Any, ros_type: str) -> bytes:
    return bytes(_store().serialize_cdr(message, ros_type))


@functools.cache
def type_hash(ros_type: str) -> str:
    """The RIHS01 hash of ``ros_type`` (``RIHS01_`` and 64 lowercase hex digits)."""
    return str(_store().hash_rihs01(ros_type))


def decode(ros_type: str, payload: bytes) -> Any:
    """The message of type ``ros_type`` in ``payload`` (CDR with its encapsulation)."""
    return _store().deserialize_cdr(payload, ros_type)


@dataclass(frozen=True)
class Stamp:
    """A ROS time (``builtin_interfaces/msg/Time``) from nanoseconds since the epoch."""

    ns: int

    def message(self) -> Any:
        sec, nanosec = divmod(self.ns, 1_000_000_000)
        return _new("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)

    def header(self, frame_id: str) -> Any:
        return _new("std_msgs/msg/Header", stamp=self.message(), frame_id=frame_id)


def bool_msg(value: bool) -> bytes:
    return _encode(_new(BOOL, data=bool(value)), BOOL)


def float32_msg(value: float) -> bytes:
    return _encode(_new(FLOAT32, data=float(value)), FLOAT32)


def float64_msg(value: float) -> bytes:
    return _encode(_new(FLOAT64, data=float(value)), FLOAT64)


def int64_msg(value: int) -> bytes:
    return _encode(_new(INT64, data=int(value)), INT64)


def _vector3(xyz: Sequence[float]) -> Any:
    return _new("geometry_msgs/msg/Vector3", x=xyz[0], y=xyz[1], z=xyz[2])


def imu(
    stamp: Stamp,
    frame_id: str,
    angular_velocity: Sequence[float],
    linear_acceleration: Sequence[float],
) -> bytes:
    """An Imu without orientation (covariance[0] = -1 says so, as REP-145 asks)."""
    no_orientation = np.zeros(9, dtype=np.float64)
    no_orientation[0] = -1.0
    message = _new(
        IMU,
        header=stamp.header(frame_id),
        orientation=_new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=no_orientation,
        angular_velocity=_vector3(angular_velocity),
        angular_velocity_covariance=np.zeros(9, dtype=np.float64),
        linear_acceleration=_vector3(linear_acceleration),
        linear_acceleration_covariance=np.zeros(9, dtype=np.float64),
    )
    return _encode(message, IMU)


def range_msg(
    stamp: Stamp,
    frame_id: str,
    metres: float,
    *,
    min_range: float,
    max_range: float,
    field_of_view: float = 0.26,
) -> bytes:
    """An ultrasound Range (radiation_type 0)."""
    message = _new(
        RANGE,
        header=stamp.header(frame_id),
        radiation_type=0,
        field_of_view=field_of_view,
        min_range=min_range,
        max_range=max_range,
        range=metres,
        variance=0.0,
    )
    return _encode(message, RANGE)


def joint_state(
    stamp: Stamp,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float],
    frame_id: str = "",
) -> bytes:
    """A JointState without efforts (an empty array says "not measured")."""
    message = _new(
        JOINT_STATE,
        header=stamp.header(frame_id),
        name=list(names),
        position=np.asarray(position, dtype=np.float64),
        velocity=np.asarray(velocity, dtype=np.float64),
        effort=np.zeros(0, dtype=np.float64),
    )
    return _encode(message, JOINT_STATE)


def battery_state(stamp: Stamp, frame_id: str, voltage: float) -> bytes:
    """A BatteryState that knows only its voltage (the rest NaN or unknown, as the
    message's comments ask for what is not measured)."""
    nan = float("nan")
    message = _new(
        BATTERY_STATE,
        header=stamp.header(frame_id),
        voltage=voltage,
        temperature=nan,
        current=nan,
        charge=nan,
        capacity=nan,
        design_capacity=nan,
        percentage=nan,
        power_supply_status=0,
        power_supply_health=0,
        power_supply_technology=0,
        present=True,
        cell_voltage=np.zeros(0, dtype=np.float32),
        cell_temperature=np.zeros(0, dtype=np.float32),
        location="",
        serial_number="",
    )
    return _encode(message, BATTERY_STATE)


@dataclass(frozen=True)
class Status:
    """One ``DiagnosticStatus``."""

    level: int
    name: str
    message: str
    hardware_id: str
    values: Mapping[str, str]


def diagnostic_array(stamp: Stamp, statuses: Sequence[Status]) -> bytes:
    message = _new(
        DIAGNOSTIC_ARRAY,
        header=stamp.header(""),
        status=[
            _new(
                "diagnostic_msgs/msg/DiagnosticStatus",
                level=status.level,
                name=status.name,
                message=status.message,
                hardware_id=status.hardware_id,
                values=[
                    _new("diagnostic_msgs/msg/KeyValue", key=key, value=value)
                    for key, value in status.values.items()
                ],
            )
            for status in statuses
        ],
    )
    return _encode(message, DIAGNOSTIC_ARRAY)
