"""The board describes itself (issue 29): the library checks pins against what it reported.

Oracles: the FakeBoard's model (what the board said) and its request count (nothing was
sent); the model data of protocol/boards.py for the wire round trip.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest

from arduinoio_async import A0, A1, A4, D2, D3, D9, D10, D11, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board, Mega2560Board, WrongBoardModelError
from arduinoio_async.errors import BoardError, PinCapabilityError, PinRoleError
from arduinoio_async.protocol import pins, pins_mega
from arduinoio_async.protocol.boards import (
    BOARD_MODELS,
    MEGA2560,
    UNO_R3,
    WIRE_FUNCTIONS,
    BoardModel,
    model_from_pages,
)
from arduinoio_async.protocol.pins import TABLE_III, Function
from arduinoio_async.testing import FakeBoard


def smaller_uno() -> BoardModel:
    """An Uno-like board that can do less: servo only on D9, no D13, only A0 analog."""
    functions = dict(UNO_R3.functions)
    functions[Function.SERVO_PWM] = (9,)
    functions[Function.DIGITAL_OUTPUT] = tuple(n for n in range(2, 13))
    functions[Function.ANALOG_INPUT] = (14,)
    return dataclasses.replace(UNO_R3, functions=functions)


@asynccontextmanager
async def on_fake(**fake: object) -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with (
        FakeBoard(board_id=0x0042, **fake) as board_fake,  # type: ignore[arg-type]
        Board.connect(board_fake.host_stream, timeout=0.5, ready_timeout=2) as board,
    ):
        yield board, board_fake


async def test_a_board_reporting_fewer_pins_refuses_one_outside_them_before_sending() -> None:
    async with on_fake(model=smaller_uno()) as (board, fake):
        sent = fake.requests_seen
        with pytest.raises(PinCapabilityError, match="D10 cannot do servo PWM") as servo:
            await board.servo(D10)
        assert servo.value.capable == ("D9",)
        with pytest.raises(PinCapabilityError, match="D13 cannot do digital output"):
            await board.digital_output(D13)
        with pytest.raises(PinCapabilityError, match="A1 cannot do analog input"):
            board.analog(A1)
        with pytest.raises(PinCapabilityError, match="A1 cannot do analog input"):
            async with board.stream(analog=[A1]):
                pass
        assert fake.requests_seen == sent  # refused here: nothing went to the board
        await board.servo(D9)  # what it reported it can do still works
        await board.digital_output(D2)
        assert fake.requests_seen == sent + 2
        board.analog(A0)


async def test_the_model_is_what_the_board_reported() -> None:
    async with on_fake(model=smaller_uno()) as (board, _fake):
        assert board.model.name == "Arduino Uno R3" and board.model.mcu == "ATmega328P"
        assert board.model.pin_names(Function.SERVO_PWM) == ("D9",)
        assert board.model.functions == smaller_uno().functions


async def test_an_image_without_the_description_is_an_uno() -> None:
    """No Feature.BOARD_DESCRIPTION: the request is never sent (the fake would answer
    UNKNOWN_DESCRIPTOR and the open would fail) and Table III applies."""
    async with on_fake(describes=False) as (board, _fake):
        assert not board.capabilities.features & p.Feature.BOARD_DESCRIPTION
        assert board.model is UNO_R3
        with pytest.raises(PinCapabilityError, match="D2 cannot do servo PWM"):
            await board.servo(D2)  # type: ignore[arg-type]


async def test_a_mega_is_checked_against_the_mega_pins() -> None:
    """D9/D10 are Timer2's on the Mega (the board's tick), D2/D3 its Timer3's."""
    async with on_fake(model=MEGA2560) as (board, fake):
        assert board.model.key == "mega2560" and board.model.pin_count == 70
        assert board.model.functions == MEGA2560.functions
        sent = fake.requests_seen
        with pytest.raises(PinCapabilityError, match="D9 cannot do servo PWM") as servo:
            await board.servo(D9)
        assert servo.value.capable[:3] == ("D2", "D3", "D5")
        assert fake.requests_seen == sent
        # D11 is OC1A on the Mega: no Uno-only refusal (Timer2 is the Uno's tick)
        assert board.model.can(D11, Function.DUTY_PWM)


@pytest.mark.parametrize("model", list(BOARD_MODELS.values()), ids=lambda m: m.key)
def test_the_wire_form_gives_back_the_model(model: BoardModel) -> None:
    pages = [model.page(i) for i in range(model.pages)]
    assert all(len(page) <= p.BOARD_PAGE_BYTES for page in pages)
    width = model.map_bytes
    maps = b"".join(pages)
    chunks = [maps[i : i + width] for i in range(0, len(maps), width)]
    assert len(chunks) == len(WIRE_FUNCTIONS)
    back = model_from_pages(model.model_id, model.digital_pins, model.analog_pins, chunks)
    assert back.functions == {f: model.pin_numbers(f) for f in WIRE_FUNCTIONS}
    assert (back.name, back.mcu, back.key) == (model.name, model.mcu, model.key)


def test_the_pages_fit_the_largest_reply() -> None:
    """Fixed fields + length byte + maps within the firmware's reply data (MAX_BLOB + 3)."""
    layout = p.ReadBoardDescriptionReply.LAYOUT
    assert layout.data_size + p.BOARD_PAGE_BYTES <= p.MAX_BLOB + 3
    assert (UNO_R3.pages, MEGA2560.pages) == (2, 5)


def test_the_uno_model_is_table_iii() -> None:
    for function in Function:
        assert UNO_R3.pin_names(function) == tuple(pin.name for pin in TABLE_III[function])


def test_a_plain_number_is_refused_with_the_pin_it_meant() -> None:
    with pytest.raises(PinCapabilityError, match="3 is a number, not a pin: use D3"):
        MEGA2560.require(3, Function.SERVO_PWM)
    assert MEGA2560.can(D3, Function.COUNTER) and not MEGA2560.can(A0, Function.I2C)


@pytest.mark.parametrize(
    ("literal", "function"),
    [
        (pins_mega.MegaServoPin, Function.SERVO_PWM),
        (pins_mega.MegaDutyPwmPin, Function.DUTY_PWM),
        (pins_mega.MegaSoftPwmPin, Function.SOFT_PWM),
        (pins_mega.MegaCounterPin, Function.COUNTER),
        (pins_mega.MegaSpiCsPin, Function.SPI_CS),
    ],
)
def test_the_mega_pin_types_are_the_mega_model_data(literal: object, function: Function) -> None:
    assert tuple(int(pin) for pin in typing.get_args(literal)) == MEGA2560.pin_numbers(function)


async def test_a_mega_board_opens_on_a_mega_and_refuses_an_uno() -> None:
    async with (
        FakeBoard(board_id=0x0042, model=MEGA2560) as fake,
        Mega2560Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as mega,
    ):
        assert isinstance(mega, Mega2560Board) and mega.model.key == "mega2560"
        with pytest.raises(PinCapabilityError, match="D9 cannot do servo PWM"):
            await mega.servo(D9)  # type: ignore[arg-type]
    async with FakeBoard(board_id=0x0042) as fake:
        with pytest.raises(WrongBoardModelError, match="is an Arduino Uno R3, not an Arduino"):
            async with Mega2560Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2):
                pass


async def test_a_fake_mega_drives_the_megas_own_pins() -> None:
    """FakeBoard in Mega mode: its pins and their functions are the MEGA2560 data."""
    async with (
        FakeBoard(board_id=0x0042, model=MEGA2560) as fake,
        Mega2560Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as mega,
    ):
        output = await mega.digital_output(pins.D40)
        await output.write(True)
        assert fake.levels[40] is True
        fake.drive(53, True)
        assert (await (await mega.digital_input(pins.D53)).read()).level
        await mega.servo(pins.D44, pulse_us=1500)
        assert fake.pulses[44] == 1500
        await mega.counter(pins.D18)
        assert fake.role(18) == "counter"


async def test_the_fake_refuses_on_the_wire_what_its_model_cannot_do() -> None:
    """The fake's own checks follow its model too (a request sent past the library)."""
    async with on_fake(model=smaller_uno()) as (board, _fake):
        with pytest.raises(BoardError) as refused:
            await board.request(p.GpioConfig(13, p.GpioFlags.OUTPUT))
        assert refused.value.code == p.ErrorCode.PIN_NOT_CAPABLE
        with pytest.raises(BoardError) as refused:
            await board.request(p.PwmConfig(10, 1500))
        assert refused.value.code == p.ErrorCode.PIN_NOT_CAPABLE


async def test_a_fake_megas_analog_inputs_and_i2c_pins_are_the_megas() -> None:
    """A12 reads on a Mega; its I2C is on D20/D21, so A4 stays an analog input with the bus
    on (on an Uno A4/A5 are the bus's)."""
    async with (
        FakeBoard(board_id=0x0042, model=MEGA2560) as fake,
        Mega2560Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as mega,
    ):
        fake.analog[12] = 700
        assert await mega.analog(pins.A12).read() == 700
        await mega.i2c()
        fake.analog[4] = 300
        assert await mega.analog(pins.A4).read() == 300
    async with on_fake() as (uno, _fake):
        await uno.i2c()
        with pytest.raises(PinRoleError, match="A4 is in use as I2C"):
            uno.analog(A4)
