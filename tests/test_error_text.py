"""Error messages say in words what was refused and why."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from arduinoio_async import A0, D3, D4, D9, BoardError, BoardTimeoutError, PinCapabilityError
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardSilentError
from arduinoio_async.protocol._messages import REQUEST_TYPES
from arduinoio_async.protocol.commands.descriptions import DESCRIPTIONS, describe

from .fake_boards import connected

BUSY_HINT = (
    "{pin} already has another role on the board (given by an earlier command or program; "
    "roles last until released or reset): free it with board.release({pin}) or "
    "`arduinoio release {pin}`, or reset the board with `arduinoio reset`"
)


def test_every_request_class_has_a_description_in_words() -> None:
    assert set(DESCRIPTIONS) == set(REQUEST_TYPES.values())
    for cls in REQUEST_TYPES.values():
        dataclass: Any = cls
        values = {
            item.name: (bytes(2) if item.name in ("items", "data") else 0)
            for item in dataclasses.fields(dataclass)
        }
        values.update({"pin": 4} if "pin" in values else {})
        text = describe(cls(**values))
        assert text and cls.__name__ not in text and "=" not in text, (cls, text)


@pytest.mark.parametrize(
    ("request_", "words"),
    [
        (
            p.GpioConfig(D4, p.GpioFlags.OUTPUT | p.GpioFlags.INITIAL_HIGH),
            "make D4 a digital output (initially high)",
        ),
        (p.GpioConfig(D4, p.GpioFlags.PULL_UP), "make D4 a digital input with pull-up"),
        (p.PwmConfig(D3, 1500), "make D3 a software PWM output (1500 us pulses)"),
        (p.PwmConfig(D9, 1200), "make D9 a servo PWM output (1200 us pulses)"),
        (p.GpioWrite(D4, True), "set D4 high"),
        (p.AnalogRead(0), "read A0"),
        (p.I2CRead(0x50, 0x10, 3), "read 3 bytes from register 0x10 of I2C device 0x50"),
    ],
)
def test_requests_in_words(request_: p.Request[p.Reply], words: str) -> None:
    assert describe(request_) == words


async def test_a_refusal_names_the_request_and_the_reason_in_words() -> None:
    async with connected() as (board, _fake):
        await board.request(p.PwmConfig(D4, 1500))
        with pytest.raises(BoardError) as refused:
            await board.request(p.GpioConfig(D4, p.GpioFlags.OUTPUT | p.GpioFlags.INITIAL_HIGH))
    assert str(refused.value) == (
        "board refused to make D4 a digital output (initially high): the pin is busy ("
        + BUSY_HINT.format(pin="D4")
        + ")"
    )
    assert refused.value.code is p.ErrorCode.PIN_BUSY


async def test_a_plain_number_for_a_pin_gets_the_pin_to_use() -> None:
    async with connected() as (board, _fake):
        with pytest.raises(PinCapabilityError) as wrong:
            board.gpio(13)  # type: ignore[arg-type]
        assert str(wrong.value) == (
            "13 is a number, not a pin: use D13 (from arduinoio_async import D13)"
        )
        with pytest.raises(PinCapabilityError) as wrong:
            board.analog(0)  # type: ignore[arg-type]
        assert str(wrong.value) == (
            "0 is a number, not a pin: use A0 (from arduinoio_async import A0)"
        )
        with pytest.raises(PinCapabilityError) as wrong:
            board.gpio(1)  # type: ignore[arg-type]
        assert str(wrong.value) == (
            "1 is a number, not a pin: digital output is available on D2, D3, D4, D5, D6, "
            "D7, D8, D9, D10, D11, D12, D13"
        )
        assert board.analog(A0).pin is A0


@pytest.mark.parametrize(
    ("heard", "words"),
    [
        (b"", "it sent nothing at 1000000 baud; either the baud rate is wrong"),
        (b"\x14\x10", "this board runs a bootloader only"),
        (b"\x3e\x00", "it sent 3e 00, which is no reply of this firmware; either"),
    ],
)
def test_a_silent_board_gets_the_likely_causes(heard: bytes, words: str) -> None:
    error = BoardSilentError("/dev/ttyACM0", heard, baudrate=1_000_000)
    assert str(error).startswith("/dev/ttyACM0 did not answer an ID request")
    assert words in str(error)
    assert isinstance(error, BoardTimeoutError)
