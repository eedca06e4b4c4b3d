"""The board's stepper method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea, like ``_motor_methods``: it combines the pin-role
machinery (``_new_handle`` of :mod:`._pin_methods`, ``set_up``, ``roles``) with
:mod:`arduinoio_async.board.steppers`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import UsageError
from ..protocol.pins import DigitalPin, Function
from ._pin_methods import PinMethods
from .steppers import Stepper, StepperPin, check_acceleration, check_speed

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["StepperMethods"]


class StepperMethods(PinMethods):
    """``board.stepper()``: a step/dir stepper in one of the board's four slots."""

    async def stepper(
        self,
        *,
        step: DigitalPin,
        dir: DigitalPin,
        max_speed: int = 1000,
        acceleration: int = 1000,
    ) -> Stepper:
        """A stepper on a driver's STEP and DIR inputs (A4988, DRV8825, TMC2209), any of
        D2-D13, with a top speed (1-10,000 steps/s) and an acceleration (steps/s^2).

        Takes the lowest free slot of four; its position starts at 0.  Both pins are
        checked before either is taken (PinRoleError names the role holding one);
        UsageError when the four slots are in use.
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.STEPPER, "steppers")
        if step == dir:
            raise ValueError(f"a stepper needs two pins, got {step} for both")
        check_speed(max_speed, "stepper top speed")
        check_acceleration(acceleration)
        used = {
            h.stepper_index
            for _pin, claim in board.roles.items()
            if isinstance(h := claim.handle, StepperPin) and not h.released
        }
        free = [i for i in range(p.STEPPER_COUNT) if i not in used]
        if not free:
            raise UsageError(
                f"the board's {p.STEPPER_COUNT} stepper slots are in use: release one first"
            )
        index = free[0]
        step_pin = self._new_handle(
            step,
            Function.DIGITAL_OUTPUT,
            lambda b, q: StepperPin(b, q, f"stepper {index}'s step pin"),
        )
        dir_pin = self._new_handle(
            dir,
            Function.DIGITAL_OUTPUT,
            lambda b, q: StepperPin(b, q, f"stepper {index}'s direction pin"),
        )
        step_pin.stepper_index = dir_pin.stepper_index = index
        await board.set_up(step_pin, p.StepperConfig(index, int(step), int(dir)))
        stepper = Stepper(board, index, step_pin, dir_pin)
        try:
            profile = p.StepperProfile(index, max_speed, acceleration)
            await board.set_up(dir_pin, profile)
        except BaseException:
            await board.release(step_pin.pin)
            raise
        stepper.max_speed, stepper.acceleration = max_speed, acceleration
        return stepper
