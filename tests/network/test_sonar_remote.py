"""Sonars on a board served on the network: readings pass through the server, and one
client cannot take a sonar (or its pins, or its slot) from another."""

from __future__ import annotations

import pytest

from arduinoio_async import D7, D8, D9, D10
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_sonar_reads_the_model_and_holds_its_pins(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        await uno.sonar("D7", "D8", distance_mm=900)
        a, b = await first.get(7), await second.get(7)
        sonar = await a.sonar(D7, D8)
        await a.sonar_timing(period_ms=20)
        with pytest.raises(BoardError) as busy:  # another client's echo pin
            await b.digital_output(D8)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # another client's sonar slot
            await b.sonar(D9, D10, slot=0)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        while (await uno.sonar_status()).on(7).echoes < 2:
            pass
        reading = await sonar.read()
        assert reading.distance_mm is not None and abs(reading.distance_mm - 900) <= 9
