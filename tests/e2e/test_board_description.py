"""The Uno image describes itself as the library's Uno model data (issue 29).

The oracle is the firmware running on the virtual Uno: its READ_BOARD_DESCRIPTION pages,
decoded by the library at open, must equal protocol/boards.py's UNO_R3 (the paper's Table
III), and a page past the last is refused by the board.
"""

from __future__ import annotations

import io
import json

import anyio
import pytest
from rich.console import Console

from arduinoio_async import protocol as p
from arduinoio_async.blocking import open_board
from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import BoardError
from arduinoio_async.protocol.boards import UNO_R3, WIRE_FUNCTIONS
from arduinoio_async.protocol.pins import Function
from arduinoio_async.protocol.profiles import UNO_PROFILES
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .test_blocking import virtual_uno

pytestmark = pytest.mark.sim


@pytest.mark.parametrize("name", UNO_PROFILES)
async def test_every_uno_image_describes_the_uno_model(
    virtual_uno_factory: VirtualUnoFactory, name: str
) -> None:
    uno = await virtual_uno_factory(profile=name)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.capabilities.features & p.Feature.BOARD_DESCRIPTION
        assert board.model.model_id == p.BoardModelId.UNO_R3
        assert (board.model.digital_pins, board.model.analog_pins) == (14, 6)
        assert board.model.functions == {f: UNO_R3.pin_numbers(f) for f in WIRE_FUNCTIONS}
        first = await board.request(p.ReadBoardDescription(0))
        assert first.maps == UNO_R3.page(0)
        with pytest.raises(BoardError) as past:
            await board.request(p.ReadBoardDescription(UNO_R3.pages))
        assert past.value.code == p.ErrorCode.VALUE_OUT_OF_RANGE


async def test_info_prints_the_model_and_the_pins_per_function(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=2)

    def info(*more: str) -> str:
        buffer = io.StringIO()
        console = Console(file=buffer, width=200)
        assert cli_main(["info", "--port", uno.port, *more], console=console) == 0
        return buffer.getvalue()

    text = await anyio.to_thread.run_sync(info)
    assert "Arduino Uno R3 (ATmega328P)" in text
    assert "pins: servo PWM" in text and "D9, D10" in text and "D2-D13" in text
    raw = json.loads(await anyio.to_thread.run_sync(info, "--json"))
    assert raw["model"]["key"] == "uno_r3" and raw["model"]["mcu"] == "ATmega328P"
    assert raw["model"]["pins"]["servo_pwm"] == ["D9", "D10"]
    assert raw["model"]["pins"]["analog_input"] == [f"A{n}" for n in range(6)]


def test_a_blocking_board_has_the_model_too() -> None:
    with virtual_uno(board_id=0x0031) as uno, open_board(uno.port) as board:
        assert board.model.key == "uno_r3"
        assert board.model.pin_names(Function.SERVO_PWM) == ("D9", "D10")
