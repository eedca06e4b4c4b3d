"""The monitor's device panels on the virtual Uno: an encoder set up from the page, its
count from the board, reset; a motor's speed, brake; an image without a class says so.

The oracle is the harness's quadrature generator (its position in quarter steps), never
the library's reading of its own answer.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest

from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from ..e2e.pulses import fresh_pulses
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


async def level(uno: VirtualUno, pin: str) -> int:
    return (await uno.pin(pin)).level


async def rows_until(tab: Page, done: Any) -> list[dict[str, Any]]:
    """The encoder rows of the first snapshot for which ``done(rows)`` holds."""
    with anyio.fail_after(10):
        while True:
            rows: list[dict[str, Any]] = (await tab.receive("board"))["encoders"]["rows"]
            if done(rows):
                return rows


async def test_an_encoder_set_up_on_the_page_shows_the_boards_count(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory()
    for pin in ("D4", "D5"):
        await uno.drive(pin, 0)  # held low before the encoder's pull-ups lift them
    async with monitored(uno) as tab:
        first = await tab.call("encoder", a="D4", b="D5", mode="x4")
        assert first["ok"] and first["data"] == 0
        await uno.quadrature("D4", "D5", edges=400, rate=2_000, reverse=0.05, seed=3)
        (truth,) = await uno.wait_quadrature()
        rows = await rows_until(tab, lambda rows: rows and rows[0]["count"] == truth.position)
        assert rows[0]["pins"] == "D4/D5" and rows[0]["invalid"] == 0
        again = await tab.call("encoder", a="D4", b="D6")
        assert not again["ok"] and "D4" in again["error"]  # the pin's other user, named
        reset = await tab.call("encoder_reset", slot=0)
        assert reset["ok"] and reset["data"] == truth.position
        await rows_until(tab, lambda rows: rows and rows[0]["count"] == 0)


async def test_an_image_without_a_class_says_so(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The sensing image has no steppers: their view says so, encoders' is there."""
    uno = await virtual_uno_factory(profile="sensing")
    async with monitored(uno) as tab:
        snapshot = await tab.receive("board")
        assert snapshot["steppers"] == {"supported": False, "rows": []}
        assert snapshot["encoders"] == {"supported": True, "rows": []}


async def test_a_motor_set_up_on_the_page_drives_its_pins(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """L298N wiring from the page (PWM D9, IN1 D7, IN2 D8): the speed slider's value reaches
    the pins the fixture measures; brake and coast show on the pins too."""
    uno = await virtual_uno_factory()
    async with monitored(uno) as tab:
        made = await tab.call("motor", kind="dir", pwm="D9", in1="D7", in2="D8")
        assert made["ok"] and made["data"] == 0
        assert (await tab.call("motor_speed", index=0, speed=-0.5))["ok"]
        with anyio.fail_after(10):
            while True:
                rows = (await tab.receive("board"))["motors"]["rows"]
                if rows and rows[0]["speed"] == -0.5:
                    break
        assert rows[0]["pins"] == "D9/D7/D8" and rows[0]["state"] == "running"
        assert (await level(uno, "D7"), await level(uno, "D8")) == (0, 1)  # reverse
        stats = await fresh_pulses(uno, "D9", 6, within=10.0)
        duty = sum(stats.high_us[-4:]) / sum(stats.period_us[-4:])
        assert abs(duty - 0.5) < 0.02, stats
        assert (await tab.call("motor_brake", index=0))["ok"]
        assert (await level(uno, "D7"), await level(uno, "D8")) == (1, 1)
        refused = await tab.call("motor_speed", index=3, speed=0.1)
        assert not refused["ok"] and "no motor 3" in refused["error"]


async def test_a_sonar_set_up_on_the_page_shows_the_models_distance(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The oracle: the harness's sonar model (the distance it answers for)."""
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D7", "D8", distance_mm=640)
    async with monitored(uno) as tab:
        made = await tab.call("sonar", trigger="D7", echo="D8")
        assert made["ok"] and made["data"] == 0
        with anyio.fail_after(10):
            while True:
                rows = (await tab.receive("board"))["sonars"]["rows"]
                if rows and rows[0]["distance_mm"] is not None:
                    break
        assert rows[0]["pins"] == "D7/D8" and abs(rows[0]["distance_mm"] - 640) <= 7
        assert (await uno.sonar_status()).on(7).echoes >= 1
        again = await tab.call("sonar", trigger="D8", echo="D9")
        assert not again["ok"] and "D8" in again["error"]  # the pin's other user, named
