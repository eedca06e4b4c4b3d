"""The monitor shows each stepper's position and target (issue 26): the page's board
message carries them, read from the board while the stepper moves."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D2, D3
from arduinoio_async.board import Board

from .test_server import fake_monitor, page, ws_url

monitor = pytest.importorskip("arduinoio_async.monitor")


async def test_the_page_shows_a_steppers_position_and_target() -> None:
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        board: Board = server.hub.panels["b0"].board
        stepper = await board.stepper(step=D2, dir=D3, max_speed=2000, acceleration=20_000)
        await stepper.move_to(400)
        with anyio.fail_after(5):
            while True:
                rows = (await tab.receive("board"))["steppers"]["rows"]
                if rows and not rows[0]["moving"] and rows[0]["position"] == 400:
                    break
        assert rows == [
            {
                "index": 0,
                "pins": "D2/D3",
                "position": 400,
                "target": 400,
                "speed": 0,
                "moving": False,
            }
        ]
        assert fake.steppers.steps_out[2] == 400  # the board's truth
