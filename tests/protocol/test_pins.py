"""Table III: what each pin can do, and the errors that name the capable pins."""

from __future__ import annotations

import pytest

from arduinoio_async import A4, D2, D3, D9, D10, D13, PinCapabilityError
from arduinoio_async.protocol.pins import Function, capable_pins, pin_mask, require


def test_servo_on_a_non_servo_pin_names_d9_and_d10() -> None:
    with pytest.raises(PinCapabilityError, match="servo PWM is available on D9, D10"):
        require(D2, Function.SERVO_PWM)


@pytest.mark.parametrize(
    ("function", "pins"),
    [
        (Function.SERVO_PWM, (D9, D10)),
        (Function.COUNTER, (D2, D3)),
        (Function.I2C, (A4,)),
    ],
)
def test_capable_pins_pass(function: Function, pins: tuple[object, ...]) -> None:
    for pin in pins:
        require(pin, function)


def test_plain_integers_are_not_pins() -> None:
    with pytest.raises(PinCapabilityError):
        require(9, Function.SERVO_PWM)


def test_masks_cover_table_iii() -> None:
    assert pin_mask(Function.DIGITAL_OUTPUT) == 0x3FFC
    assert pin_mask(Function.SOFT_PWM) == 0x00FC
    assert D13 in capable_pins(Function.DIGITAL_INPUT)
