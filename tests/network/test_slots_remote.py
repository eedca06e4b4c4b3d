"""Slots of a served board that its clients cannot collide on.

The slots of a class (encoders, sonars, pulse inputs) are the board's, shared by every
client of a served board, and a client sees only its own handles.  Before the fix client
B's ``b.sonar(D9, D10)`` picked slot 0 that client A held and was refused "the pin is
busy".  Now the server refuses a held slot with SLOT_BUSY and a client that did not name
the slot takes the next free one; a client that names a held slot gets SLOT_BUSY; a
client that disconnects frees its slots for the next one.  Oracles: the server's refusal
codes, and for sonars the harness's model distance read through the slot a client got.
"""

from __future__ import annotations

import pytest

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11, D12
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_three_clients_default_sonar_slots_do_not_collide(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
        RemoteBoards(connect=[served.endpoint]) as third,
    ):
        uno = served.unos[7]
        await uno.sonar("D9", "D10", distance_mm=1600)
        a, b, c = await first.get(7), await second.get(7), await third.get(7)
        sonars = [await a.sonar(D7, D8), await b.sonar(D9, D10), await c.sonar(D11, D12)]
        assert [s.slot for s in sonars] == [0, 1, 2]
        with pytest.raises(BoardError) as busy:  # a named slot another client holds
            await c.sonar(D2, D3, slot=1)
        assert busy.value.code is p.ErrorCode.SLOT_BUSY
        await b.sonar_timing(period_ms=20)
        while (await uno.sonar_status()).on(9).echoes < 2:
            pass
        reading = await sonars[1].read()  # B's sonar in board slot 1 is the D9/D10 model
        assert reading.distance_mm is not None and abs(reading.distance_mm - 1600) <= 16


async def test_three_clients_default_encoder_slots_and_a_leaver(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7]) as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as third,
    ):
        a, c = await first.get(7), await third.get(7)
        async with RemoteBoards(connect=[served.endpoint]) as second:
            b = await second.get(7)
            encoders = [await a.encoder(a=D2, b=D3), await b.encoder(a=D4, b=D5)]
            assert [e.slot for e in encoders] == [0, 1]
            with pytest.raises(BoardError) as busy:
                await c.encoder(a=D6, b=D7, slot=1)
            assert busy.value.code is p.ErrorCode.SLOT_BUSY
        # B is gone: its slot 1 is the next free one for C
        assert (await c.encoder(a=D6, b=D7)).slot == 1
        assert (await c.encoder(a=D8, b=D9)).slot == 2


async def test_three_clients_default_pulse_input_slots_do_not_collide(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
        RemoteBoards(connect=[served.endpoint]) as third,
    ):
        a, b, c = await first.get(7), await second.get(7), await third.get(7)
        inputs = [await a.pulse_input(D7), await b.pulse_input(D8), await c.pulse_input(D9)]
        assert [i.slot for i in inputs] == [0, 1, 2]
        with pytest.raises(BoardError) as busy:
            await b.pulse_input(D10, slot=0)
        assert busy.value.code is p.ErrorCode.SLOT_BUSY
