"""The sonar handle against the FakeBoard: no simulator, milliseconds.

The FakeBoard's sonar model fires at the object the test sets in front of it and turns
the echo into millimetres as the firmware does; the oracle is that distance.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest

from arduinoio_async import D4, D5, D6, D7, D8, D9
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.sonars import speed_of_sound
from arduinoio_async.board.streaming import stream_request
from arduinoio_async.errors import PinRoleError, StaleHandleError, ValueRangeError
from arduinoio_async.testing import FakeBoard


@asynccontextmanager
async def connected() -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        yield board, fake


async def test_distances_no_echo_and_the_speed_of_sound() -> None:
    async with connected() as (board, fake):
        sonar = await board.sonar(D7, D8)
        first = await sonar.read()
        assert first.distance_mm is None and not first.no_echo and first.readings == 0
        fake.set_sonar(7, 1000)
        reading = await sonar.read()
        assert reading.distance_mm == 1000 and reading.echo_us == 5831
        fake.set_sonar(7, None)
        reading = await sonar.read()
        assert reading.no_echo and reading.distance_mm is None and reading.echo_us == 0
        await board.sonar_timing(period_ms=25, temperature_c=0.0)
        assert (fake.sonar_period_ms, fake.sonar_speed_dm_s) == (25, 3313)
        assert abs(speed_of_sound(20.0) - 343.2) < 0.1
        fake.set_sonar(7, 500)
        assert await sonar.distance_mm() == 500


async def test_roles_release_and_the_timing_replayed_after_a_reset() -> None:
    async with connected() as (board, fake):
        sonar = await board.sonar(D7, D8)
        await board.sonar_timing(period_ms=30, speed_m_s=340.0)
        with pytest.raises(PinRoleError, match="sonar echo"):
            await board.digital_output(D8)
        with pytest.raises(PinRoleError, match="sonar trigger"):
            await board.encoder(D6, D7)
        # what a board that reset gets back: the sonar and the timing in force
        setups = board.roles.setups()
        assert p.SonarConfig(0, 7, 8) in setups and p.SonarTiming(30, 3400) in setups
        await sonar.release()
        with pytest.raises(StaleHandleError):
            await sonar.read()
        assert 0 not in fake.sonars
        await board.digital_output(D8)  # free again


async def test_the_stream_decodes_each_sonar_slot() -> None:
    async with connected() as (board, fake):
        await board.sonar(D4, D5)
        await board.sonar(D6, D9, slot=2)
        fake.set_sonar(4, 250)
        fake.set_sonar(6, None)
        async with board.stream(sonars=True, period_ms=5) as samples:
            async for sample in samples:
                assert sample.sonars is not None
                near, free, far = sample.sonars
                break
        assert near.distance_mm == 250 and not near.no_echo
        assert free.distance_mm is None and not free.no_echo and free.age_ms is None
        assert far.no_echo


def test_a_stream_with_too_many_bytes_is_refused_before_sending() -> None:
    with pytest.raises(ValueRangeError, match="sonars 1 \\+ 3 a slot"):
        stream_request([], False, False, True, 1.0, True, True, 30, 4)
