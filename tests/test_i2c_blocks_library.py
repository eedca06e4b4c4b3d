"""I2C blocks in the stream and the MPU-6050 helper against the FakeBoard: no simulator.

The FakeBoard's block model reads its fake devices' registers each sample (as the
firmware's interrupt-driven read does); the oracle is the register bytes the test wrote
into the fake device.
"""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest

from arduinoio_async import A0, I2CBlock, I2CSpeed
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.i2c_blocks import block_errors
from arduinoio_async.board.imu import MPU6050, STANDARD_GRAVITY
from arduinoio_async.errors import I2CError, UsageError, ValueRangeError
from arduinoio_async.testing import FakeBoard


def mpu_registers() -> bytearray:
    regs = bytearray(256)
    regs[0x75] = 0x68
    # accel x = +0.5 g, y = -0.25 g, z = 1 g at +-4 g (8192 LSB/g); temp raw -3920;
    # gyro x = 100 dps at +-500 (65.5 LSB/dps), y = -50, z = 0
    values = (4096, -2048, 8192, -3920, 6550, -3275, 0)
    for i, v in enumerate(values):
        regs[0x3B + 2 * i : 0x3D + 2 * i] = v.to_bytes(2, "big", signed=True)
    return regs


@asynccontextmanager
async def connected() -> AsyncIterator[tuple[Board, FakeBoard]]:
    fake = FakeBoard()
    fake.i2c_devices[0x68] = mpu_registers()
    async with fake, Board.connect(fake.host_stream) as board:
        yield board, fake


async def test_stream_carries_the_devices_bytes_and_nacks_as_none() -> None:
    async with connected() as (board, fake):
        bus = await board.i2c(I2CSpeed.KHZ_400)
        imu = MPU6050(bus)
        await imu.configure(accel_g=4, gyro_dps=500)
        regs = fake.i2c_devices[0x68]
        async with board.stream(analog=[A0], i2c=[imu.block], period_ms=1) as samples:
            first = await anext(aiter(samples))
            assert first.i2c == (bytes(regs[0x3B:0x49]),) and first.i2c_status == (0,)
            reading = imu.decode(first.i2c[0])
            assert reading.accel == pytest.approx(
                (0.5 * STANDARD_GRAVITY, -0.25 * STANDARD_GRAVITY, STANDARD_GRAVITY)
            )
            assert reading.gyro == pytest.approx((math.radians(100), math.radians(-50), 0.0))
            assert reading.temperature_c == pytest.approx(25.0, abs=0.01)
            with pytest.raises(I2CError) as caught:
                await bus.read(0x68, 0x75, 1)
            assert caught.value.code == p.ErrorCode.I2C_STREAMING
            del fake.i2c_devices[0x68]  # unplugged: NACKs
            async for sample in samples:
                if sample.i2c == (None,):
                    assert sample.i2c_status == (p.ErrorCode.I2C_NACK_ADDRESS,)
                    break
        assert await block_errors(board, 0) >= 1


async def test_bad_blocks_are_refused_before_sending() -> None:
    async with connected() as (board, _fake):
        with pytest.raises(UsageError, match="bus"):
            async with board.stream(i2c=[I2CBlock(0x68, 0x3B, 14)], period_ms=1):
                pass
        await board.i2c()
        with pytest.raises(ValueRangeError):
            I2CBlock(0x80, 0, 1)
        with pytest.raises(ValueRangeError, match="at most 16"):
            async with board.stream(
                i2c=[I2CBlock(0x68, 0x3B, 14), I2CBlock(0x50, 0, 4)], period_ms=1
            ):
                pass
        with pytest.raises(ValueRangeError, match="1-2 a stream"):
            async with board.stream(i2c=[I2CBlock(0x50, 0, 1)] * 3, period_ms=1):
                pass
        with pytest.raises(UsageError, match="I2CBlock"):
            async with board.stream(i2c=[(0x68, 0x3B, 14)], period_ms=1):  # type: ignore[list-item]
                pass


async def test_imu_helper_checks_its_arguments_and_the_device() -> None:
    async with connected() as (board, fake):
        bus = await board.i2c()
        with pytest.raises(ValueRangeError):
            MPU6050(bus, 0x50)
        imu = MPU6050(bus)
        with pytest.raises(ValueRangeError):
            await imu.configure(accel_g=3)  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError):
            await imu.configure(gyro_dps=100)  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError):
            await imu.configure(dlpf=7)
        fake.i2c_devices[0x68][0x75] = 0x12
        with pytest.raises(UsageError, match="WHO_AM_I 0x12"):
            await imu.configure()
        with pytest.raises(ValueError, match="14 bytes"):
            imu.decode(None)
        assert await bus.scan() == [0x50, 0x68]


def test_mypy_refuses_ranges_the_part_does_not_have(tmp_path: Path) -> None:
    """The ranges are Literal types: a range the MPU-6050 lacks is a type error."""
    snippet = tmp_path / "misuse.py"
    snippet.write_text(
        textwrap.dedent(
            """
            from arduinoio_async import MPU6050

            async def main(imu: MPU6050) -> None:
                await imu.configure(accel_g=4, gyro_dps=500)
                await imu.configure(accel_g=3)
                await imu.configure(gyro_dps=300)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(snippet)],
        capture_output=True,
        text=True,
        check=False,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert [e.split(":")[1] for e in errors] == ["6", "7"], result.stdout
