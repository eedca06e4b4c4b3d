"""What the monitor shows of pins it did not set up, and of outputs' edges; and a loopback
address other than 127.0.0.1 serves its own page."""

from __future__ import annotations

from typing import Any

import anyio
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard

from .test_browser import browser, expect
from .test_server import fake_monitor, page, ws_url

monitor = pytest.importorskip("arduinoio_async.monitor")
__all__ = ["browser"]  # the fixture, imported for the page test


async def test_pins_set_up_elsewhere_show_their_role() -> None:
    """Roles another program (or another client of a served board) gave are the board's:
    the page shows them as set elsewhere, not as free, and can take such a pin over."""
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        # What an earlier program left: D2 an output driven high, D9 a servo.
        board: Board = server.hub.panels["b0"].board
        await board.request(p.GpioConfig(2, p.GpioFlags.OUTPUT | p.GpioFlags.INITIAL_HIGH))
        await board.request(p.PwmConfig(9, 1200))
        assert fake.role(2) == "output" and fake.role(9) == "pwm"  # the board's truth
        with anyio.fail_after(5):
            while True:
                pins = {pin["name"]: pin for pin in (await tab.receive("board"))["pins"]}
                if pins["D2"]["role"] != "free" and pins["D9"]["role"] != "free":
                    break
        assert (pins["D2"]["role"], pins["D2"]["elsewhere"]) == ("elsewhere", "digital output")
        assert (pins["D9"]["role"], pins["D9"]["elsewhere"]) == ("elsewhere", "servo PWM")
        assert pins["D3"]["role"] == "free" and pins["D3"]["elsewhere"] is None
        # Taking one over: the page's role replaces the one set elsewhere.
        assert (await tab.call("role", pin="D2", role="input"))["ok"]
        assert fake.role(2) == "input"
        with anyio.fail_after(5):
            while True:
                pins = {pin["name"]: pin for pin in (await tab.receive("board"))["pins"]}
                if pins["D2"]["role"] == "input":
                    break
        assert pins["D2"]["elsewhere"] is None


async def test_an_outputs_edges_are_counted() -> None:
    """The board latches edges of inputs only; an output's edges come from its levels in
    the stream, so a toggled output's counts move."""
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        assert (await tab.call("role", pin="D4", role="output"))["ok"]
        with anyio.fail_after(5):  # the stream knows the level before the first write
            while not (await tab.receive("samples"))["known"] & 1 << 4:
                pass
        for level in (1, 0, 1):
            assert (await tab.call("write", pin="D4", value=level))["ok"]
            with anyio.fail_after(5):  # the stream saw the level before the next write
                while bool((await tab.receive("samples"))["levels"] & 1 << 4) != bool(level):
                    pass
        assert fake.levels[4]
        samples = await tab.receive("samples")
        assert (samples["rises"][4 - 2], samples["falls"][4 - 2]) == (2, 1)


async def test_another_loopback_address_serves_its_own_page() -> None:
    async with (
        FakeBoard() as fake,
        Board.connect(fake.host_stream) as board,
        monitor.serve_monitor([board], http="127.0.0.2:0") as server,
    ):
        async with await anyio.connect_tcp("127.0.0.2", server.port) as stream:
            request = (
                f"GET / HTTP/1.1\r\nHost: 127.0.0.2:{server.port}\r\nConnection: close\r\n\r\n"
            )
            await stream.send(request.encode())
            head = b""
            while b"\r\n" not in head:
                head += await stream.receive()
        assert head.split()[1] == b"200", head


async def test_the_page_shows_roles_set_elsewhere_and_a_servo_without_pulses(
    browser: Any,
) -> None:
    async with (
        FakeBoard(board_id=0x2A) as fake,
        Board.connect(fake.host_stream) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", period_ms=10) as server,
    ):
        web = await browser.new_page()
        await web.goto(server.url)
        section = web.locator('section.board[data-board-id="42"]')
        await expect(section.locator(".title")).to_have_text("Board 0x002A")
        # An output D2 and a servo D9 set up by another program.
        await board.request(p.GpioConfig(2, p.GpioFlags.OUTPUT | p.GpioFlags.INITIAL_HIGH))
        d2 = section.locator('tr[data-pin="D2"]')
        await expect(d2).to_have_attribute("data-elsewhere", "digital output")
        await expect(d2.locator("select.role option:checked")).to_have_text(
            "digital output (set elsewhere)"
        )
        await expect(d2.locator(".control")).to_have_text("set by another program or client")
        # A servo chosen on the page sends no pulses yet: its slider says so.
        d9 = d2.locator("xpath=..").locator('tr[data-pin="D9"]')
        await d9.locator("select.role").select_option("servo")
        await expect(d9.locator("input.pulse")).to_have_class("pulse off")
        await expect(d9.locator("output")).to_have_text("off")
        assert fake.role(9) == "pwm" and not fake.pulses.get(9)
        await d9.locator("input.pulse").fill("1700")
        await expect(d9.locator("output")).to_have_text("1700 µs")
        await expect(d9.locator("input.pulse")).to_have_class("pulse")
        with anyio.fail_after(5):
            while fake.pulses.get(9) != 1700:
                await board.read_id()  # a round trip: the page's request goes first
