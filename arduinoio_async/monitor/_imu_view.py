"""The monitor's IMU view: an MPU-6050/6500 on the board's I2C bus, set up from the page,
its acceleration, rotation and temperature read every READ_INTERVAL (one-shot 14-byte
reads, so the page's own analog stream keeps its layout) and plotted as three accel and
three gyro traces on the page (uPlot)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .. import protocol as p
from ..board.handles import I2CBus
from ..board.imu import ACCEL_RANGES_G, GYRO_RANGES_DPS, MPU6050
from ..errors import UsageError
from ._devices import Action, DeviceView

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["ImuView"]


class ImuView(DeviceView):
    """One MPU-6050 at 0x68 or 0x69: set up from the page (ranges), read every interval."""

    key = "imu"
    feature = p.Feature.I2C

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        super().__init__(board, on_change=on_change)
        self.imu: MPU6050 | None = None

    async def read_rows(self) -> list[dict[str, object]]:
        if self.imu is None:
            return []
        r = await self.imu.read()
        return [
            {
                "address": self.imu.address,
                "accel": [round(a, 3) for a in r.accel],
                "gyro": [round(w, 4) for w in r.gyro],
                "temperature_c": round(r.temperature_c, 2),
                "accel_g": self.imu.accel_g,
                "gyro_dps": self.imu.gyro_dps,
            }
        ]

    def actions(self) -> dict[str, Action]:
        return {"imu": self._set_up}

    async def _set_up(self, args: Mapping[str, Any]) -> str:
        """``{"address": 104, "accel_g": 4, "gyro_dps": 500}``: wake and configure it."""
        accel, gyro = int(args.get("accel_g", 2)), int(args.get("gyro_dps", 250))
        if accel not in ACCEL_RANGES_G or gyro not in GYRO_RANGES_DPS:
            raise UsageError("accel_g is 2, 4, 8 or 16 and gyro_dps 250, 500, 1000 or 2000")
        held = self.board.roles.i2c
        bus = held if isinstance(held, I2CBus) else await self.board.i2c(p.I2CSpeed.KHZ_400)
        imu = MPU6050(bus, int(args.get("address", 0x68)))
        await imu.configure(accel_g=accel, gyro_dps=gyro)
        self.imu = imu
        await self.read()
        return f"MPU-6050 at 0x{imu.address:02X}: +-{accel} g, +-{gyro} dps"
