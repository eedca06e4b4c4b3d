"""The paper's real-time sensor system on one board: every sensor in one 1 kHz stream.

The paper's robot needed a second firmware for its IMU and wheel encoders (Sec. V); here
the sensing image streams four analog channels, two quadrature encoders, the
MPU-6050's register block and a sonar's latest distance together, every period, while
commands keep working.  The oracles are the harness's models: the analog fixture's
voltages, the quadrature generators' positions, the bytes the MPU-6050 model served on
each read, the distance the sonar model answers for.  The 60 s run
is ``python -m benchmarks.sensors_imu --encoders``; this one takes a few seconds.
"""

from __future__ import annotations

from itertools import pairwise

import anyio
import pytest

from arduinoio_async import A0, A1, A2, A3, D2, D3, D4, D7, D8, D12, I2CSpeed
from arduinoio_async.board import Board
from arduinoio_async.board.imu import MPU6050
from arduinoio_async.board.streaming import Sample
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .imu_log import served

pytestmark = pytest.mark.sim

ANALOG = [A0, A1, A2, A3]
MILLIVOLTS = [600, 1800, 3100, 4400]
#: 3 s of samples at 1 kHz.
SAMPLES = 3000


async def test_analog_encoders_imu_and_sonar_in_one_1khz_stream(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """3,000 samples at 1 ms: no gap, no drop; every IMU block is the model's read of that
    period; the analog channels hold the fixture's voltages; the encoders' streamed counts
    end at the generators' positions, reached without a count going backwards on a
    forward-only generator; the sonar's distance in every sample once it has one is the
    model's (within 1 %), each reading no older than the firing period allows."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    for channel, mv in enumerate(MILLIVOLTS):
        await uno.set_analog(channel, mv)
    for name in ("D2", "D3", "D4", "D12"):
        await uno.drive(name, 0)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        left = await board.encoder(a=D2, b=D3)
        right = await board.encoder(a=D4, b=D12)
        imu = MPU6050(await board.i2c(I2CSpeed.KHZ_400))
        await imu.configure(accel_g=4, gyro_dps=500)
        await uno.sonar("D7", "D8", distance_mm=1500)
        await board.sonar(D7, D8)
        await board.sonar_timing(period_ms=40)
        first_read = (await uno.command("imu"))["logged"]
        got: list[Sample] = []
        with anyio.fail_after(120):
            async with board.stream(
                analog=ANALOG,
                encoders=True,
                i2c=[imu.block],
                sonars=True,
                period_ms=1,
                buffer=SAMPLES,
            ) as samples:
                async for sample in samples:
                    got.append(sample)
                    if len(got) == 1:
                        # Both wheels turn while the stream runs: 4,000 edges each.
                        await uno.quadrature("D2", "D3", edges=4_000, rate=2_000)
                        await uno.quadrature("D4", "D12", edges=4_000, rate=2_000, direction=-1)
                    if len(got) == SAMPLES:
                        break
                gaps, dropped = samples.gaps, samples.dropped
            generators = await uno.wait_quadrature()
            truth = await served(uno, first_read)
        assert (gaps, dropped) == (0, 0)
        assert all((b.sequence - a.sequence) & 0xFFFF == 1 for a, b in pairwise(got))
        # Each period's block is one read of the model, in order, none failed.
        blocks = [s.i2c[0] if s.i2c else None for s in got]
        assert None not in blocks
        start = truth.index(blocks[0])  # type: ignore[arg-type]
        assert blocks == truth[start : start + SAMPLES]
        for pin, mv in zip(ANALOG, MILLIVOLTS, strict=True):
            codes = {s.analog[pin] for s in got}
            assert max(abs(c - mv * 1024 / 5000) for c in codes) <= 3, (pin, codes)
        position = {g.a: g.position for g in generators}
        streamed = [s.encoders for s in got if s.encoders is not None]
        assert len(streamed) == SAMPLES
        left_counts = [e[left.slot] for e in streamed]
        right_counts = [e[right.slot] for e in streamed]
        assert all(b >= a for a, b in pairwise(left_counts))
        assert all(b <= a for a, b in pairwise(right_counts))
        # The generators finished (2 s) before the last sample (3 s).
        assert (left_counts[-1], right_counts[-1]) == (position[2], position[4]) == (4000, -4000)
        assert ((await left.read()).count, (await right.read()).count) == (4000, -4000)
        sonar = [s.sonars[0] for s in got if s.sonars is not None]
        assert len(sonar) == SAMPLES
        heard = [r for r in sonar if r.distance_mm is not None]
        assert len(heard) >= SAMPLES - 100  # the first firing's echo comes within 100 ms
        assert all(abs(r.distance_mm - 1500) <= 15 for r in heard if r.distance_mm is not None)
        assert all(r.age_ms is not None and r.age_ms < 50 for r in heard)
        assert (await uno.sonar_status()).on(7).echoes >= SAMPLES // 40 - 2
