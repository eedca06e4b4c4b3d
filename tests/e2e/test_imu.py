"""I2C register blocks in the stream and the MPU-6050 helper, on the virtual Uno.

Every oracle is the harness's MPU-6050 model (firmware/sim/mpu6050.c): the 14 bytes it
served on each read and the simulated time of the read (``imu_reads``), the NACKs it gave
(``imu``), its register state; its motion is a known function of simulated time.  The
60 s run is ``python -m benchmarks.sensors_imu``; these take seconds.
"""

from __future__ import annotations

import io
import math
from typing import Any

import anyio
import anyio.to_thread
import pytest
from rich.console import Console

from arduinoio_async import A0, A1, A2, A3, I2CBlock, I2CSpeed, blocking
from arduinoio_async import protocol as p
from arduinoio_async.blocking import BlockingMPU6050
from arduinoio_async.board import Board
from arduinoio_async.board.i2c_blocks import block_errors
from arduinoio_async.board.imu import MPU6050, STANDARD_GRAVITY, ImuReading
from arduinoio_async.board.streaming import Sample
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import I2CError, UsageError
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def served(uno: VirtualUno, first: int) -> list[tuple[float, bytes]]:
    """The model's logged reads from index ``first`` on: (simulated us, 14 bytes)."""
    out: list[tuple[float, bytes]] = []
    while True:
        reply: dict[str, Any] = await uno.command("imu_reads", **{"from": first + len(out)})
        assert reply["from"] == first + len(out), "the model's log ring overran"
        out += [(float(us), bytes(data)) for us, data in reply["reads"]]
        if first + len(out) >= reply["logged"]:
            return out


async def collect(samples: Any, count: int) -> list[Sample]:
    got: list[Sample] = []
    async for sample in samples:
        got.append(sample)
        if len(got) == count:
            return got
    raise AssertionError("the stream ended")


async def open_imu(board: Board) -> MPU6050:
    bus = await board.i2c(I2CSpeed.KHZ_400)
    imu = MPU6050(bus)
    await imu.configure(accel_g=4, gyro_dps=500, dlpf=3)
    return imu


async def test_stream_samples_equal_the_models_reads(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """4 analog channels + the IMU block at 1 kHz, 1 Mbaud, 2,000 samples: every sample's
    block is exactly the bytes the model served on its read, in order, read within the
    sample's own period, with 0 gaps and 0 bus errors."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        imu = await open_imu(board)
        state = await uno.command("imu")
        assert (state["pwr_mgmt_1"], state["accel_config"], state["gyro_config"]) == (1, 8, 8)
        first = state["logged"]
        async with board.stream(analog=[A0, A1, A2, A3], i2c=[imu.block], period_ms=1) as samples:
            got = await collect(samples, 2000)
        assert samples.gaps == 0 and samples.dropped == 0
        assert await block_errors(board, 0) == 0
    reads = await served(uno, first)
    assert len(reads) >= len(got)
    assert [s.sequence for s in got] == list(range(len(got)))
    assert [s.i2c for s in got] == [(data,) for _, data in reads[: len(got)]]
    # each read began within its sample's period: board time and simulated time differ by
    # a constant plus the read's start latency
    offsets = [us - s.board_time_us for (us, _), s in zip(reads, got, strict=False)]
    assert max(offsets) - min(offsets) < 500, (min(offsets), max(offsets))


async def test_nack_marks_the_field_invalid_and_is_counted(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """5 NACKed address phases: 5 samples carry None with the NACK's code, the board
    counts 5, and the stream goes on with 0 gaps."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        imu = await open_imu(board)
        async with board.stream(analog=[A0], i2c=[imu.block], period_ms=1) as samples:
            got = await collect(samples, 50)
            await uno.command("imu", nack=5)
            got += await collect(samples, 200)
        nacked = (await uno.command("imu"))["nacked"]
        errors = await block_errors(board, 0)
    bad = [s for s in got if s.i2c == (None,)]
    assert nacked == 5 and errors == 5 and len(bad) == 5
    assert all(s.i2c_status == (p.ErrorCode.I2C_NACK_ADDRESS,) for s in bad)
    assert samples.gaps == 0
    good = [s.i2c for s in got if s.i2c != (None,)]
    assert len(good) == len(got) - 5 and all(len(b[0] or b"") == 14 for b in good if b)


async def test_one_shot_reads_scale_to_the_models_motion(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The helper's SI values equal the model's physical motion at the read's simulated
    time (to one LSB of the ranges set), and the model saw the ranges the helper wrote."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        imu = await open_imu(board)
        first = (await uno.command("imu"))["logged"]
        readings = [await imu.read() for _ in range(5)]
    reads = await served(uno, first)
    assert len(reads) == 5
    g_lsb = 4 * STANDARD_GRAVITY / 32768
    w_lsb = math.radians(1) / 65.5
    for (us, data), reading in zip(reads, readings, strict=True):
        t = us / 1e6
        w = 2 * math.pi
        assert reading == imu.decode(data)
        accel = (0.5 * math.sin(w * t), 0.25 * math.cos(w * t), 1.0)
        gyro = (100 * math.sin(w * 0.5 * t), -50.0, 200 * math.cos(w * 0.5 * t))
        for got_a, g in zip(reading.accel, accel, strict=True):
            assert abs(got_a - g * STANDARD_GRAVITY) <= g_lsb
        for got_w, dps in zip(reading.gyro, gyro, strict=True):
            assert abs(got_w - math.radians(dps)) <= w_lsb
        assert abs(reading.temperature_c - (25 + 2 * math.sin(w * 0.1 * t))) <= 1 / 340


async def test_bus_is_the_streams_and_bad_blocks_are_refused(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """While a stream reads blocks a one-shot read is refused with words; blocks beyond
    the board's limits and a stream before the bus is set up are refused before sending."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(UsageError, match=r"board\.i2c"):
            async with board.stream(i2c=[I2CBlock(0x68, 0x3B, 14)], period_ms=1):
                pass
        imu = await open_imu(board)
        with pytest.raises(UsageError, match="I2C block bytes"):
            async with board.stream(i2c=[imu.block, I2CBlock(0x50, 0, 8)], period_ms=1):
                pass
        with pytest.raises(UsageError, match="I2C block length"):
            I2CBlock(0x68, 0x3B, 0)
        async with board.stream(i2c=[imu.block], period_ms=1) as samples:
            await collect(samples, 5)
            with pytest.raises(I2CError, match="stream") as caught:
                await imu.read()
            assert caught.value.code == p.ErrorCode.I2C_STREAMING
            await collect(samples, 5)
        assert (await imu.read()).accel[2] > 9  # the bus is free again


async def test_i2c_scan_finds_the_imu_and_the_eeprom(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """``arduinoio i2c scan`` lists the addresses that acknowledge: the fixture's 24C
    EEPROM (0x50) and the MPU-6050 model (0x68); with the model off the bus only 0x50."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    buffer = io.StringIO()
    args = ["i2c", "scan", "--port", uno.port, "--baud", str(uno.baud)]
    code = await anyio.to_thread.run_sync(
        lambda: cli_main(args, console=Console(file=buffer, width=200))
    )
    assert code == 0 and buffer.getvalue().split() == ["0x50", "0x68"], buffer.getvalue()
    await uno.command("imu", present=False)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert await (await board.i2c()).scan() == [0x50]


async def test_blocking_imu_streams_the_block(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The blocking twins: scan, configure, a stream of the IMU block decoded by the
    blocking helper, each reading equal to the model's served bytes decoded."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")

    def script() -> tuple[list[int], list[bytes | None], list[ImuReading]]:
        with blocking.open_board(uno.port, baudrate=uno.baud) as board:
            bus = board.i2c(I2CSpeed.KHZ_400)
            found = bus.scan()
            imu = BlockingMPU6050(bus)
            imu.configure(accel_g=8, gyro_dps=1000)
            blocks: list[bytes | None] = []
            with board.stream(i2c=[imu.block], period_ms=2) as samples:
                for sample in samples:
                    assert sample.i2c is not None
                    blocks.append(sample.i2c[0])
                    if len(blocks) == 20:
                        break
            return found, blocks, [imu.decode(b) for b in blocks]

    first = (await uno.command("imu"))["logged"]
    found, blocks, readings = await anyio.to_thread.run_sync(script)
    reads = await served(uno, first)
    assert found == [0x50, 0x68]
    assert blocks == [data for _, data in reads[:20]]
    assert all(abs(r.accel[2] - STANDARD_GRAVITY) < 0.01 for r in readings)  # z = 1 g


async def test_cli_stream_prints_the_imu_block(virtual_uno_factory: VirtualUnoFactory) -> None:
    """``arduinoio stream --imu --i2c ...``: the IMU in SI units and a second block (the
    fixture's EEPROM, whose bytes the test wrote) in hex, with the counts."""
    uno = await virtual_uno_factory(baud=1_000_000, profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await (await board.i2c()).write(0x50, 0x20, b"\xca\xfe")
    buffer = io.StringIO()
    args = ["stream", "--imu", "--i2c", "0x50:0x20:2", "--period-ms", "2", "--seconds", "0.5"]
    args += ["--every", "50", "--port", uno.port, "--baud", str(uno.baud)]
    code = await anyio.to_thread.run_sync(
        lambda: cli_main(args, console=Console(file=buffer, width=300))
    )
    out = buffer.getvalue()
    assert code == 0, out
    assert "block1=cafe" in out and "+9.81) m/s^2" in out, out
    assert "gaps 0, dropped 0, failed block reads 0" in out, out
