"""The monitor page in a real browser (Debian's chromium, headless) on a virtual Uno.

The loopback fixture jumpers D2-D3, D4-D5, D8-D9: what the page drives on one pin, the
board reads on its neighbour and the fixture measures on the wire, so every check has an
oracle outside the page.  Set ``ARDUINOIO_MONITOR_SCREENSHOT=docs/images/monitor.png`` to
refresh the README's screenshot from this test.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import anyio
import pytest
import pytest_asyncio

from arduinoio_async.board import Board
from arduinoio_async.sim import PulseStats, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from ..e2e.pulses import fresh_pulses

pytestmark = pytest.mark.sim

playwright_api = pytest.importorskip("playwright.async_api")
monitor = pytest.importorskip("arduinoio_async.monitor")
expect = playwright_api.expect

CHROMIUM = Path(os.environ.get("ARDUINOIO_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_FOUND = CHROMIUM.is_file()
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest_asyncio.fixture
async def browser() -> AsyncIterator[Any]:
    """Headless system Chromium (Playwright never downloads a browser here)."""
    if not CHROMIUM_FOUND:
        if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
            pytest.fail(f"{CHROMIUM} missing: apt-get install chromium (make setup does)")
        pytest.skip(f"{CHROMIUM} missing: apt-get install chromium")
    async with playwright_api.async_playwright() as pw:
        browser = await pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield browser
        finally:
            await browser.close()


async def pulses_settle(uno: VirtualUno, pin: str, width_us: float, tolerance: float) -> PulseStats:
    """The fixture's capture on ``pin`` once three fresh pulses are ``width_us`` wide.

    One budget for the whole wait: the page's request may reach the board late on a busy
    machine, and a capture that waits for its first pulses is part of the same wait.
    """
    deadline = anyio.current_time() + 10
    while True:
        stats = await fresh_pulses(uno, pin, 3, within=deadline - anyio.current_time())
        if all(abs(h - width_us) <= tolerance for h in stats.high_us):
            return stats


async def test_monitor_page_drives_and_follows_a_virtual_uno(
    virtual_uno_factory: VirtualUnoFactory, browser: Any, tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=0x2A, fixture="loopback")
    await uno.set_analog(0, 1000)
    await uno.set_analog(1, 2500)
    async with (
        Board.open(uno.port) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", period_ms=10) as server,
    ):
        page = await browser.new_page(viewport={"width": 1360, "height": 900})
        await page.goto(server.url)
        section = page.locator('section.board[data-board-id="42"]')
        await expect(section.locator(".title")).to_have_text("Board 0x002A")
        await expect(section.locator('[data-fact="stream"]')).to_have_attribute(
            "data-running", "true"
        )

        # D2 output -> jumper -> D3 input: the page shows what the board reads on D3.
        d2 = section.locator('tr[data-pin="D2"]')
        d3_led = section.locator('tr[data-pin="D3"] .led')
        await expect(d3_led).to_have_attribute("data-level", "0")
        # The board latches edges on pins with an input role.
        await section.locator('tr[data-pin="D3"] select.role').select_option("input")
        await expect(section.locator(".message")).to_have_text("D3 is now input")
        # D3's level and edges now come from the board's change events.
        await expect(section.locator('tr[data-pin="D3"]')).to_have_attribute(
            "data-source", "changes"
        )
        await expect(section.locator('[data-fact="changes"]')).to_have_attribute(
            "data-running", "true"
        )
        await d2.locator("select.role").select_option("output")
        await d2.locator("input.out").check()
        await expect(d3_led).to_have_attribute("data-level", "1")
        await d2.locator("input.out").uncheck()
        await expect(d3_led).to_have_attribute("data-level", "0")
        await expect(section.locator('tr[data-pin="D3"] .edges')).to_have_text("1 / 1")

        # Servo slider on D9: the fixture measures the pulse on the wire.
        d9 = section.locator('tr[data-pin="D9"]')
        await d9.locator("select.role").select_option("servo")
        await d9.locator("input.pulse").fill("1700")
        stats = await pulses_settle(uno, "D9", 1700, tolerance=1)
        assert all(abs(period - 20000) <= 20 for period in stats.period_us[1:]), stats
        # Software PWM slider on D4 (100 us steps).
        d4 = section.locator('tr[data-pin="D4"]')
        await d4.locator("select.role").select_option("soft_pwm")
        await d4.locator("input.pulse").fill("1200")
        await pulses_settle(uno, "D4", 1200, tolerance=12)

        # The analog plot follows the voltage the fixture sets on A0.
        for millivolts in (3300, 1500):
            await uno.set_analog(0, millivolts)
            raw = round(millivolts * 1024 / 5000)
            await page.wait_for_function(
                """([raw]) => {
                  const plot = window.arduinoioMonitor.boards.b0.plot;
                  const column = plot.data[1];
                  const shown = column.slice(-5);
                  return shown.length === 5 && shown.every(v => Math.abs(v * 1024 / 5 - raw) <= 3);
                }""",
                arg=[raw],
                timeout=5000,
            )
            readout = section.locator('.readouts [data-channel="A0"] .value')
            shown_raw = int(await readout.get_attribute("data-raw") or -1)
            assert abs(shown_raw - raw) <= 3, (shown_raw, raw)
            await expect(readout).to_have_text(f"{shown_raw * 5 / 1024:.3f} V")

        # I2C register write and read back through the page (EEPROM at 0x50 on the fixture).
        form = section.locator("form.i2c")
        await form.locator('input[name="register"]').fill("0x10")
        await form.locator('input[name="data"]').fill("c0 ff ee")
        await form.locator(".i2c-write").click()
        await expect(form.locator(".i2c-result")).to_have_text("wrote 3 bytes")
        assert await uno.eeprom_i2c(0x10, 3) == bytes.fromhex("c0ffee")
        # A refused control comes back as the library's message (no device at 0x51).
        await form.locator('input[name="address"]').fill("0x51")
        await form.locator(".i2c-read").click()
        message = section.locator(".message")
        await expect(message).to_have_attribute("data-error", "true")
        await expect(message).to_contain_text("no I2C device answered at that address")
        await form.locator('input[name="address"]').fill("0x50")

        # Reset from the page: the board reboots, the monitor puts every role back and the
        # stream resumes (D9 pulses again, D3 follows D2 again, the I2C bus answers).
        await d2.locator("input.out").check()
        await expect(d3_led).to_have_attribute("data-level", "1")
        await section.locator("button.reset").click()
        await expect(message).to_have_text("board reset; roles restored", timeout=10_000)
        await pulses_settle(uno, "D9", 1700, tolerance=1)
        await d2.locator("input.out").uncheck()
        await expect(d3_led).to_have_attribute("data-level", "0")
        await form.locator('input[name="length"]').fill("3")
        await form.locator(".i2c-read").click()
        await expect(form.locator(".i2c-result")).to_have_text("read: c0 ff ee")

        await d2.locator("input.out").check()  # lit LEDs for the screenshot
        await expect(d3_led).to_have_attribute("data-level", "1")

        shot = tmp_path / "monitor.png"
        await page.screenshot(path=str(shot), full_page=True)
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        target = os.environ.get("ARDUINOIO_MONITOR_SCREENSHOT")
        if target:
            shutil.copyfile(shot, target)
        await page.close()


async def test_the_page_counts_every_edge_from_change_events_with_the_stream_off(
    virtual_uno_factory: VirtualUnoFactory, browser: Any
) -> None:
    """The fixture's pulse generator drives D3 faster than any stream could count; the
    stream is off, so the level and the exact edge count can only come from events."""
    uno = await virtual_uno_factory(board_id=0x2B, fixture="open")
    async with (
        Board.open(uno.port) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", stream=False) as server,
    ):
        page = await browser.new_page(viewport={"width": 1360, "height": 900})
        await page.goto(server.url)
        section = page.locator('section.board[data-board-id="43"]')
        await expect(section.locator('[data-fact="stream"]')).to_have_text(
            "off (inputs: change events only)"
        )
        d3 = section.locator('tr[data-pin="D3"]')
        await expect(d3.locator(".led")).to_have_attribute("data-level", "")  # nothing knows it
        await d3.locator("select.role").select_option("input")
        await expect(d3).to_have_attribute("data-source", "changes")
        await expect(d3.locator(".led")).to_have_attribute("data-level", "0")  # read once

        await uno.pulses("D3", count=40, high_us=2000, low_us=2000)
        await uno.wait_pulses()
        done = (await uno.status())["pulses_done"]["3"]
        assert done == 40, done
        await expect(d3.locator(".edges")).to_have_text("40 / 40")
        await expect(d3.locator(".led")).to_have_attribute("data-level", "0")
        changes = section.locator('[data-fact="changes"]')
        await expect(changes).to_have_text("D3 · 80 events, 0 lost")
        # Other pins: no source knows their level with the stream off.
        await expect(section.locator('tr[data-pin="D4"] .led')).to_have_attribute("data-level", "")
        await page.close()


async def test_the_duty_slider_sets_the_duty_the_fixture_measures(
    virtual_uno_factory: VirtualUnoFactory, browser: Any
) -> None:
    """A duty-cycle PWM pin's slider (0.1 % steps) on D3, Timer2's 10 kHz."""
    uno = await virtual_uno_factory(board_id=0x2B)
    async with (
        Board.open(uno.port) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", period_ms=10) as server,
    ):
        page = await browser.new_page(viewport={"width": 1360, "height": 900})
        await page.goto(server.url)
        section = page.locator('section.board[data-board-id="43"]')
        d3 = section.locator('tr[data-pin="D3"]')
        await d3.locator("select.role").select_option("duty")
        await expect(section.locator(".message")).to_have_text("D3 is now duty-cycle PWM")
        await d3.locator("input.duty").fill("370")
        await expect(d3.locator("output")).to_have_text("37.0 %")
        # 100 us periods of 200 timer counts: 37 % is 74 counts, 37 us high
        await pulses_settle(uno, "D3", 37.0, tolerance=0.5 + 0.25)
        await page.close()
