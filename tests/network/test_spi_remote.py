"""The SPI bridge on a board served on the network: transfers pass through the server, and
one client cannot take the bus (or its pins) from another."""

from __future__ import annotations

import pytest

from arduinoio_async import D4, D10, D12
from arduinoio_async import protocol as p
from arduinoio_async.devices import MCP3008
from arduinoio_async.errors import BoardError
from arduinoio_async.network import RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_spi_bus_reads_and_holds_its_pins(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7], profile="sensing") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        await uno.spi_device(cs=10, volts=[0.0, 0.0, 3.3])
        a, b = await first.get(7), await second.get(7)
        adc = await MCP3008.open(a, cs=D10)
        assert abs(await adc.read_channel(2) - 3.3) <= 5 / 1024
        with pytest.raises(BoardError) as busy:  # the board would take a new chip select
            await b.spi(cs=D4)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:
            await b.digital_output(D12)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        assert abs(await adc.read_channel(2) - 3.3) <= 5 / 1024
        truth = await uno.spi_device_status()
        assert truth.cs_falls == truth.cs_rises == truth.conversions == 2
