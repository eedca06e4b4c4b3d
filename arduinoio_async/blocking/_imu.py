"""The blocking twin of :class:`~arduinoio_async.board.imu.MPU6050`:
``BlockingMPU6050(board.i2c(I2CSpeed.KHZ_400))``."""

from __future__ import annotations

from ..board.i2c_blocks import I2CBlock
from ..board.imu import DEFAULT_ADDRESS, MPU6050, AccelRange, GyroRange, ImuReading
from ._handles import BlockingI2CBus

__all__ = ["BlockingMPU6050"]


class BlockingMPU6050:
    """Blocking :class:`~arduinoio_async.board.imu.MPU6050` on a blocking I2C bus; its
    :meth:`decode` and :attr:`block` serve a blocking stream's samples the same way."""

    def __init__(self, bus: BlockingI2CBus, address: int = DEFAULT_ADDRESS) -> None:
        self._runner = bus._runner
        self.imu = MPU6050(bus.handle, address)

    @property
    def block(self) -> I2CBlock:
        """The data registers as a stream block: ``board.stream(i2c=[imu.block])``."""
        return self.imu.block

    def configure(
        self, *, accel_g: AccelRange = 2, gyro_dps: GyroRange = 250, dlpf: int = 0
    ) -> None:
        """Check WHO_AM_I, wake the device and set the ranges and the low-pass filter."""
        self._runner.call(lambda: self.imu.configure(accel_g=accel_g, gyro_dps=gyro_dps, dlpf=dlpf))

    def read(self) -> ImuReading:
        """One reading now, in SI units."""
        return self._runner.call(self.imu.read)

    def decode(self, data: bytes | None) -> ImuReading:
        """A stream sample's 14 bytes in SI units (the ranges :meth:`configure` set)."""
        return self.imu.decode(data)
