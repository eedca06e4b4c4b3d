"""The monitor's SPI panel on the virtual Uno: set up from the page, a transfer answered by
the harness's MCP3008 (its own record is the oracle), release; an image without SPI says so."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest

from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .test_server import Page, page, ws_url

monitor = pytest.importorskip("arduinoio_async.monitor")
pytestmark = pytest.mark.sim


@asynccontextmanager
async def monitored(uno: VirtualUno) -> AsyncIterator[Page]:
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", period_ms=20) as server,
        page(ws_url(server)) as tab,
    ):
        yield tab


async def spi_until(tab: Page, done: Any) -> dict[str, Any]:
    with anyio.fail_after(10):
        while True:
            spi: dict[str, Any] = (await tab.receive("board"))["spi"]
            if done(spi):
                return spi


async def test_a_bus_set_up_on_the_page_transfers(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    await uno.spi_device(cs=10, volts=[2.5])
    async with monitored(uno) as tab:
        setup = await tab.call("spi", cs="D10", mode=0, clock_hz=1_000_000)
        assert setup["ok"], setup
        reply = await tab.call("spi_transfer", data="01 80 00")
        assert reply["ok"], reply
        truth = await uno.spi_device_status()
        assert reply["data"] == truth.frames[-1].miso.hex(" ") and truth.cs_falls == 1
        spi = await spi_until(tab, lambda s: s["rows"] and "received" in s["rows"][0])
        assert spi["rows"][0]["cs"] == "D10" and spi["rows"][0]["received"] == reply["data"]
        bad = await tab.call("spi_transfer", data="zz")
        assert not bad["ok"] and "not hex bytes" in bad["error"]
        assert (await tab.call("spi_release"))["ok"]
        await spi_until(tab, lambda s: s["rows"] == [])


async def test_an_image_without_spi_says_so(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(profile="standard")
    async with monitored(uno) as tab:
        spi = (await tab.receive("board"))["spi"]
        assert spi == {"supported": False, "rows": []}
        refused = await tab.call("spi", cs="D10")
        assert not refused["ok"] and "sensing" in refused["error"]
