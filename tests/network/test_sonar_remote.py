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
        assert busy.value.code is p.ErrorCode.SLOT_BUSY
        while (await uno.sonar_status()).on(7).echoes < 2:
            pass
        reading = await sonar.read()
        assert reading.distance_mm is not None and abs(reading.distance_mm - 900) <= 9


async def test_one_client_streams_sonar_while_another_reads_and_a_third_sends_nonsense(
    serve_unos: ServeFactory,
) -> None:
    """Client A streams its sonar at 2 ms; client B sets up and reads a second sonar;
    client C sends sonar requests the board must refuse (a slot past the end, one pin for
    trigger and echo, the host link's pin).  A's stream has no gap, B's reading is its
    model's distance, C gets precise refusals and holds nothing."""
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
        RemoteBoards(connect=[served.endpoint]) as third,
    ):
        uno = served.unos[7]
        await uno.sonar("D7", "D8", distance_mm=900)
        await uno.sonar("D9", "D10", distance_mm=1600)
        a, b, c = await first.get(7), await second.get(7), await third.get(7)
        await a.sonar(D7, D8)
        await a.sonar_timing(period_ms=20)
        async with a.stream(sonars=True, period_ms=2) as samples:
            count = 0
            last = None
            async for sample in samples:
                last = sample
                count += 1
                if count == 1:
                    # the default slot: the server moves B past A's slot 0
                    other = await b.sonar(D9, D10)
                    assert other.slot == 1
                    for bad in (
                        p.SonarConfig(9, 9, 10),
                        p.SonarConfig(2, 9, 9),
                        p.SonarConfig(2, 1, 9),
                    ):
                        with pytest.raises(BoardError) as refused:
                            await c.request(bad)
                        assert refused.value.code in (
                            p.ErrorCode.VALUE_OUT_OF_RANGE,
                            p.ErrorCode.PIN_NOT_CAPABLE,
                            p.ErrorCode.PIN_BUSY,
                        ), bad
                    while (await uno.sonar_status()).on(9).echoes < 2:
                        pass
                    reading = await other.read()
                    assert reading.distance_mm is not None
                    assert abs(reading.distance_mm - 1600) <= 16
                if count == 300:
                    break
            assert (samples.gaps, samples.dropped) == (0, 0)
        assert last is not None and last.sonars is not None
        heard = last.sonars[0].distance_mm
        assert heard is not None and abs(heard - 900) <= 9
