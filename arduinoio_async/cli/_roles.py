"""Pin roles as the board reports them (``ReadPinRoles``), in words.

Roles outlive the program that gave them (until released or reset), so the CLI asks the
board: ``status`` and ``info`` list them, and a refusal because a pin is busy names the
role that holds it.
"""

from __future__ import annotations

from .. import protocol as p
from ..board import Board
from ..errors import BoardError
from ..protocol.pins import UNO_DIGITAL, DigitalPin, Function, pin_mask

__all__ = ["explain_busy_pin", "pin_roles"]


def _pwm_kind(pin: DigitalPin) -> str:
    return "servo PWM" if pin_mask(Function.SERVO_PWM) >> int(pin) & 1 else "software PWM"


async def pin_roles(board: Board) -> dict[str, str]:
    """Pin name -> role ("digital input", "servo PWM", ...) of every pin that has one."""
    reply = await board.request(p.ReadPinRoles())
    roles: dict[str, str] = {}
    for pin in UNO_DIGITAL:
        bit = 1 << int(pin)
        if reply.gpio_input & bit:
            roles[pin.name] = "digital input"
        elif reply.gpio_output & bit:
            roles[pin.name] = "digital output"
        elif reply.pwm & bit:
            roles[pin.name] = _pwm_kind(pin)
        elif reply.counter & bit:
            roles[pin.name] = "counter"
        elif reply.pulse_input & bit:
            roles[pin.name] = "pulse-width input"
    return roles


async def explain_busy_pin(board: Board, refused: BoardError) -> BoardError:
    """``refused`` (PIN_BUSY) again, with the role the board says holds the pin."""
    pin = getattr(refused.request, "pin", None)
    try:
        name = DigitalPin(int(pin)).name if pin is not None else None
    except ValueError:
        name = None
    if name is None:
        return refused
    role = (await pin_roles(board)).get(name)
    if role is None:
        return refused
    return type(refused)(refused.code, refused.request, f"on the board {name} is a {role}")
