"""Duty PWM and a motor on a board served on the network: the new requests pass
through the server untouched, and the fixture measures what the served board's pins do."""

from __future__ import annotations

import statistics

import pytest

from arduinoio_async import D7, D8, D9, D10
from arduinoio_async.errors import TimerBusyError
from arduinoio_async.network import open_remote_board

from ..e2e.pulses import fresh_pulses
from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_motor_drives_the_served_boards_pins(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7]) as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        uno = served.unos[7]
        motor = await board.motor(D9, D7, D8, frequency_hz=20000)
        await motor.set_speed(-0.5)
        assert ((await uno.pin("D7")).level, (await uno.pin("D8")).level) == (0, 1)
        stats = await fresh_pulses(uno, "D9", 8, within=10.0)
        assert abs(statistics.median(stats.high_us) - 25.0) <= 1 / 16 + 0.0005  # 50 us period
        with pytest.raises(TimerBusyError, match="needs Timer1, which D9 holds"):
            await board.servo(D10)
        await motor.brake()
        assert ((await uno.pin("D7")).level, (await uno.pin("D8")).level) == (1, 1)
