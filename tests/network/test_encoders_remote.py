"""Quadrature encoders on a board served on the network: the requests and the
reports pass through the server, and one client cannot take another client's encoder pins."""

from __future__ import annotations

import pytest

from arduinoio_async import D4, D5, D6, D10, D11
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_encoder_counts_and_holds_both_pins(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7]) as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        await uno.drive("D4", 0)
        await uno.drive("D5", 0)
        a, b = await first.get(7), await second.get(7)
        enc = await a.encoder(a=D4, b=D5)
        async with enc.reports(every=50) as reports:
            await uno.quadrature("D4", "D5", edges=400, rate=4_000)
            got = []
            async for state in reports:
                got.append(state.count)
                if len(got) == 8:
                    break
        position = (await uno.wait_quadrature())[0].position
        steps = [b - a for a, b in zip([0, *got], got, strict=False)]
        assert all(50 <= step <= 52 for step in steps), steps
        assert await enc.count() == position == 400
        with pytest.raises(BoardError) as busy:  # pin B is the encoder's too
            await b.encoder(a=D6, b=D5)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # and so is its slot, whatever the pins
            await b.encoder(a=D10, b=D11, slot=0)
        assert busy.value.code is p.ErrorCode.SLOT_BUSY
        other = await b.encoder(a=D10, b=D11, slot=1)
        assert await other.count() == 0 and await enc.count() == 400
