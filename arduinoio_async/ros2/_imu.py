"""An MPU-6050 on the board's I2C bridge as ``sensor_msgs/Imu``.

The MPU-6050 (I2C address 0x68, or 0x69 with AD0 high) answers ``WHO_AM_I`` (0x75) with
0x68 and sleeps until ``PWR_MGMT_1`` (0x6B) is written 0; 14 bytes from ``ACCEL_XOUT_H``
(0x3B) are accelerometer x/y/z, temperature and gyroscope x/y/z, big-endian int16.  At
the power-on ranges (+-2 g, +-250 deg/s) one g is 16384 counts and one deg/s 131 counts.
The I2C reply carries no board timestamp, so a sample is stamped with the middle of its
request's round trip on the host clock (late or early by at most half the round trip).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

__all__ = ["ACCEL_XOUT_H", "PWR_MGMT_1", "WHO_AM_I", "ImuReading", "decode"]

WHO_AM_I = 0x75
PWR_MGMT_1 = 0x6B
ACCEL_XOUT_H = 0x3B
#: Bytes from ACCEL_XOUT_H: accel xyz, temperature, gyro xyz.
LENGTH = 14
MPU6050_ID = 0x68
STANDARD_GRAVITY = 9.80665
COUNTS_PER_G = 16384.0
COUNTS_PER_DEG_S = 131.0


@dataclass(frozen=True)
class ImuReading:
    """One reading in SI units (REP-103): m/s^2 and rad/s."""

    linear_acceleration: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]


def decode(data: bytes) -> ImuReading:
    """The reading in the 14 bytes read from ACCEL_XOUT_H."""
    ax, ay, az, _temperature, gx, gy, gz = struct.unpack(">7h", data)
    g = STANDARD_GRAVITY / COUNTS_PER_G
    rad = math.radians(1.0) / COUNTS_PER_DEG_S
    return ImuReading((ax * g, ay * g, az * g), (gx * rad, gy * rad, gz * rad))
