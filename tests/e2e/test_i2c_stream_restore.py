"""A stream with I2C blocks survives a board reset: the bus and the blocks come back.

The board forgets its I2C bus and its stream blocks when it resets; the library replays
the bus with the pin roles and must replay each block before it starts the stream again,
or the samples after the reset would come without the IMU's bytes.  Oracle: the
harness's MPU-6050 model, the bytes it served on each read.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import A0, I2CSpeed
from arduinoio_async.board import Board
from arduinoio_async.board.imu import MPU6050
from arduinoio_async.board.streaming import Sample
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .imu_log import served

pytestmark = pytest.mark.sim


async def test_stream_blocks_and_bus_come_back_after_a_reset(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Samples after ``board.reset(restore=True)`` carry the IMU block again, each one a
    read the model served; a one-shot read on the bus works again too."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        bus = await board.i2c(I2CSpeed.KHZ_400)
        imu = MPU6050(bus)
        await imu.configure(accel_g=4, gyro_dps=500)
        before: list[Sample] = []
        after: list[Sample] = []
        with anyio.fail_after(60):
            async with board.stream(analog=[A0], i2c=[imu.block], period_ms=2) as samples:
                async for sample in samples:
                    before.append(sample)
                    if len(before) == 50:
                        break
                first_read = (await uno.command("imu"))["logged"]
                await board.reset(restore=True)
                async for sample in samples:
                    after.append(sample)
                    if len(after) == 50:
                        break
            truth = await served(uno, first_read)
            assert await bus.read(0x68, 0x75, 1) == b"\x68"  # WHO_AM_I: the bus is on
        assert all(s.i2c is not None and s.i2c[0] is not None for s in before)
        blocks = [s.i2c[0] if s.i2c else None for s in after]
        assert None not in blocks, blocks[:5]
        start = truth.index(blocks[0])  # type: ignore[arg-type]
        assert blocks == truth[start : start + len(blocks)]
