"""The monitor's RC inputs view: set up from the page, the rows show the harness source's
width (its ground truth), and a lost signal shows as lost; the standard image says the
class is not there."""

from __future__ import annotations

from typing import Any

import anyio
import pytest

from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .test_device_panels import monitored
from .test_server import Page

monitor = pytest.importorskip("arduinoio_async.monitor")
pytestmark = pytest.mark.sim


async def rc_rows_until(tab: Page, done: Any) -> list[dict[str, Any]]:
    """The RC input rows of the first snapshot for which ``done(rows)`` holds."""
    with anyio.fail_after(10):
        while True:
            rows: list[dict[str, Any]] = (await tab.receive("board"))["rc_inputs"]["rows"]
            if done(rows):
                return rows


async def test_an_rc_input_set_up_on_the_page_shows_the_sources_width(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    await uno.rcpulse("D7", width_us=1750, period_us=10_000)
    async with monitored(uno) as tab:
        first = await tab.call("rc_input", pin="D7", timeout_ms=50)
        assert first["ok"] and first["data"] == 0
        rows = await rc_rows_until(tab, lambda rows: rows and not rows[0]["lost"])
        truth = next(s for s in await uno.rcpulse_status() if s.pin == 7).last_width_us
        assert rows[0]["pin"] == "D7" and abs(rows[0]["width_us"] - truth) <= 2
        assert abs(rows[0]["position"] - (truth - 1500) / 500) < 0.01
        again = await tab.call("rc_input", pin="D7")
        assert not again["ok"] and "D7" in again["error"]  # the pin's user, named
        await uno.rcpulse_stop("D7")
        rows = await rc_rows_until(tab, lambda rows: rows and rows[0]["lost"])
        assert rows[0]["position"] is None


async def test_the_standard_image_has_no_rc_inputs(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory()
    async with monitored(uno) as tab:
        snapshot = await tab.receive("board")
        assert snapshot["rc_inputs"] == {"supported": False, "rows": []}
