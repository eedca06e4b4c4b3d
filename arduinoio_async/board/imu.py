"""An MPU-6050/6500 inertial measurement unit on the board's I2C bus.

The helper knows the register map the parts share: it wakes the device (PWR_MGMT_1),
sets the accelerometer range (+-2, 4, 8 or 16 g), the gyroscope range (+-250, 500, 1000
or 2000 dps) and the digital low-pass filter (CONFIG, 0-6), and turns the 14 data bytes
at ACCEL_XOUT_H (0x3B: accel x y z, temperature, gyro x y z, big-endian int16) into SI
units (:class:`ImuReading`).  The same decoding serves a one-shot :meth:`MPU6050.read`
and the board's stream: ``board.stream(i2c=[imu.block], ...)`` reads the block every
period on the board (:mod:`arduinoio_async.board.i2c_blocks`) and
``imu.decode(sample.i2c[0])`` converts it, with the ranges this helper set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from ..errors import UsageError, ValueRangeError
from .handles import I2CBus
from .i2c_blocks import I2CBlock

__all__ = [
    "ACCEL_RANGES_G",
    "DEFAULT_ADDRESS",
    "GYRO_RANGES_DPS",
    "MPU6050",
    "STANDARD_GRAVITY",
    "AccelRange",
    "GyroRange",
    "ImuReading",
]

DEFAULT_ADDRESS = 0x68  # AD0 low; 0x69 with AD0 high
STANDARD_GRAVITY = 9.80665  # m/s^2 per g

AccelRange = Literal[2, 4, 8, 16]
GyroRange = Literal[250, 500, 1000, 2000]
ACCEL_RANGES_G: tuple[AccelRange, ...] = (2, 4, 8, 16)
GYRO_RANGES_DPS: tuple[GyroRange, ...] = (250, 500, 1000, 2000)
#: The datasheet's gyroscope sensitivity per range, LSB per dps: not 32768 / range (131
#: is 0.05 % above 32768 / 250; 32.8 and 16.4 are rounded again).
GYRO_LSB_PER_DPS: dict[GyroRange, float] = {250: 131.0, 500: 65.5, 1000: 32.8, 2000: 16.4}

# Registers (MPU-6000/6050 Register Map and Descriptions, rev. 4.2)
CONFIG = 0x1A
GYRO_CONFIG = 0x1B
ACCEL_CONFIG = 0x1C
ACCEL_XOUT_H = 0x3B
PWR_MGMT_1 = 0x6B
WHO_AM_I = 0x75
DATA_LENGTH = 14
#: WHO_AM_I of the parts this helper knows: MPU-6050 0x68, MPU-6500 0x70.
KNOWN_IDS = {0x68: "MPU-6050", 0x70: "MPU-6500"}


@dataclass(frozen=True, slots=True)
class ImuReading:
    """One reading in SI units (the sensor's axes)."""

    #: Acceleration x, y, z in m/s^2 (gravity included).
    accel: tuple[float, float, float]
    #: Angular rate x, y, z in rad/s.
    gyro: tuple[float, float, float]
    #: Die temperature in degrees Celsius.
    temperature_c: float


def _int16(data: bytes, offset: int) -> int:
    return int.from_bytes(data[offset : offset + 2], "big", signed=True)


class MPU6050:
    """An MPU-6050/6500 at ``address`` on ``bus`` (``await board.i2c(I2CSpeed.KHZ_400)``).

    ``await imu.configure(accel_g=4, gyro_dps=500, dlpf=3)`` wakes it and sets the ranges;
    the ranges it sets are the ones :meth:`decode` scales by.
    """

    def __init__(self, bus: I2CBus, address: int = DEFAULT_ADDRESS) -> None:
        if address not in (0x68, 0x69):
            raise ValueRangeError("MPU-6050 address", address, "0x68 or 0x69 (AD0 low or high)")
        self.bus = bus
        self.address = address
        self.accel_g: AccelRange = 2
        self.gyro_dps: GyroRange = 250

    @property
    def block(self) -> I2CBlock:
        """The data registers as a stream block: ``board.stream(i2c=[imu.block])``."""
        return I2CBlock(self.address, ACCEL_XOUT_H, DATA_LENGTH)

    async def who_am_i(self) -> int:
        """The WHO_AM_I register (0x68 on an MPU-6050, 0x70 on an MPU-6500)."""
        return (await self.bus.read(self.address, WHO_AM_I, 1))[0]

    async def configure(
        self, *, accel_g: AccelRange = 2, gyro_dps: GyroRange = 250, dlpf: int = 0
    ) -> None:
        """Check WHO_AM_I, wake the device (clock: gyro X PLL) and set the ranges and the
        low-pass filter (0: 260 Hz accel bandwidth ... 6: 5 Hz)."""
        if accel_g not in ACCEL_RANGES_G:
            raise ValueRangeError("accelerometer range (g)", accel_g, "2, 4, 8 or 16")
        if gyro_dps not in GYRO_RANGES_DPS:
            raise ValueRangeError("gyroscope range (dps)", gyro_dps, "250, 500, 1000 or 2000")
        if not isinstance(dlpf, int) or not 0 <= dlpf <= 6:
            raise ValueRangeError("DLPF setting", dlpf, "0-6")
        ident = await self.who_am_i()
        if ident not in KNOWN_IDS:
            raise UsageError(
                f"the device at 0x{self.address:02X} answers WHO_AM_I 0x{ident:02X}: "
                "not an MPU-6050 (0x68) or MPU-6500 (0x70)"
            )
        await self.bus.write(self.address, PWR_MGMT_1, b"\x01")  # awake, PLL clock
        await self.bus.write(self.address, CONFIG, bytes([dlpf]))
        await self.bus.write(
            self.address, GYRO_CONFIG, bytes([GYRO_RANGES_DPS.index(gyro_dps) << 3])
        )
        await self.bus.write(
            self.address, ACCEL_CONFIG, bytes([ACCEL_RANGES_G.index(accel_g) << 3])
        )
        self.accel_g = accel_g
        self.gyro_dps = gyro_dps

    async def sleep(self) -> None:
        """Put the device to sleep (PWR_MGMT_1 SLEEP): its data stop changing."""
        await self.bus.write(self.address, PWR_MGMT_1, b"\x40")

    async def read(self) -> ImuReading:
        """One reading now (a one-shot I2C read of the 14 data bytes)."""
        return self.decode(await self.bus.read(self.address, ACCEL_XOUT_H, DATA_LENGTH))

    def decode(self, data: bytes | None) -> ImuReading:
        """The 14 data bytes in SI units, scaled by the ranges :meth:`configure` set;
        a stream sample's failed read (``None``) raises ValueError."""
        if data is None or len(data) != DATA_LENGTH:
            raise ValueError(f"an MPU-6050 block is {DATA_LENGTH} bytes, got {data!r}")
        accel_scale = self.accel_g * STANDARD_GRAVITY / 32768
        gyro_scale = math.radians(1) / GYRO_LSB_PER_DPS[self.gyro_dps]
        accel = tuple(_int16(data, 2 * i) * accel_scale for i in range(3))
        gyro = tuple(_int16(data, 8 + 2 * i) * gyro_scale for i in range(3))
        return ImuReading(
            (accel[0], accel[1], accel[2]),
            (gyro[0], gyro[1], gyro[2]),
            _int16(data, 6) / 340 + 36.53,
        )
