"""RC pulse inputs on a board served on the network: the widths and the stream pass through
the server, and one client cannot take another client's pulse-input pin or slot.

Oracle: the harness's RC pulse source (``uno.rcpulse_status``)."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D7, D8
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_pulse_input_reads_streams_and_holds_its_pin(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        await uno.rcpulse("D7", width_us=1420, period_us=10_000)
        a, b = await first.get(7), await second.get(7)
        rc = await a.pulse_input(D7, slot=0, timeout_ms=100)
        with anyio.fail_after(20):
            while True:  # the first pulse after set-up
                state = await rc.read()
                if not state.lost:
                    break
                await anyio.sleep(0.02)
        truth = next(s for s in await uno.rcpulse_status() if s.pin == 7).last_width_us
        assert abs(state.width_us - truth) <= 2
        with pytest.raises(BoardError) as busy:  # the first client's pin
            await b.pulse_input(D7, slot=1)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # and its slot, whatever the pin
            await b.pulse_input(D8, slot=0)
        assert busy.value.code is p.ErrorCode.SLOT_BUSY
        other = await b.pulse_input(D8, slot=1)
        assert (await other.read()).lost and not (await rc.read()).lost
        async with a.stream(pulse_inputs=True, period_ms=10) as samples:
            with anyio.fail_after(20):
                async for s in samples:
                    assert s.pulse_widths is not None and s.pulse_lost is not None
                    break
        assert s.pulse_lost is not None and s.pulse_widths is not None
        assert not s.pulse_lost[0] and abs(s.pulse_widths[0] - truth) <= 2
