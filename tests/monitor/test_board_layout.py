"""The monitor lays out the pins the board described (issue 29): 52 on a Mega, 12 on an Uno.

Oracle: the FakeBoard's model (what the board reported) and the role it holds on the wire.
"""

from __future__ import annotations

import dataclasses
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from arduinoio_async.board import Board
from arduinoio_async.errors import UsageError
from arduinoio_async.monitor._panel import BoardPanel
from arduinoio_async.protocol.boards import MEGA2560_FULL, UNO_R3, BoardModel
from arduinoio_async.protocol.pins import Function
from arduinoio_async.testing import FakeBoard


@asynccontextmanager
async def panel_on(model: BoardModel) -> AsyncIterator[tuple[BoardPanel, FakeBoard]]:
    async with (
        FakeBoard(board_id=0x0042, model=model) as fake,
        Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as board,
        anyio.create_task_group() as tg,
    ):
        panel = BoardPanel("b0", board, stream=False, period_ms=10, on_change=lambda: None)
        tg.start_soon(panel.run)
        yield panel, fake
        tg.cancel_scope.cancel()


def pins_of(snapshot: dict[str, object]) -> dict[str, list[str]]:
    rows = snapshot["pins"]
    assert isinstance(rows, list)
    return {row["name"]: row["roles"] for row in rows}


async def test_a_mega_page_shows_the_megas_pins_and_their_roles() -> None:
    async with panel_on(MEGA2560_FULL) as (panel, fake):
        pins = pins_of(panel.snapshot())
        assert list(pins) == [f"D{n}" for n in range(2, 54)]
        assert "servo" in pins["D44"] and "servo" not in pins["D9"]
        assert "soft_pwm" in pins["D24"] and "counter_rising" in pins["D18"]
        await panel.perform("role", {"pin": "D44", "role": "servo"})
        assert fake.role(44) == "pwm"
        with pytest.raises(UsageError, match="D9 cannot be servo"):
            await panel.perform("role", {"pin": "D9", "role": "servo"})


async def test_an_uno_page_is_the_unos_twelve_pins_and_a_smaller_board_shows_fewer() -> None:
    async with panel_on(UNO_R3) as (panel, _fake):
        assert list(pins_of(panel.snapshot())) == [f"D{n}" for n in range(2, 14)]
    functions = dict(UNO_R3.functions)
    functions[Function.DIGITAL_OUTPUT] = tuple(range(2, 13))
    async with panel_on(dataclasses.replace(UNO_R3, functions=functions)) as (panel, _fake):
        assert "D13" not in pins_of(panel.snapshot())


async def test_the_analog_row_follows_the_board_up_to_the_streams_eight_channels() -> None:
    """An Uno shows A0-A5; a Mega A0-A7 (the stream's analog mask is one byte)."""
    async with panel_on(UNO_R3) as (panel, _fake):
        assert panel.snapshot()["analog_pins"] == [f"A{n}" for n in range(6)]
    async with panel_on(MEGA2560_FULL) as (panel, _fake):
        assert panel.snapshot()["analog_pins"] == [f"A{n}" for n in range(8)]
