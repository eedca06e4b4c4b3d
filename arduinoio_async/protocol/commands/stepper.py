"""STEPPER commands (class tag 0x09, extension, issue 26) and the move-complete event,
handled by ``firmware/src/stepper_cmd.c`` (requests) and
``firmware/src/stepper.c`` (the motion).

Up to STEPPER_COUNT step/dir drivers (A4988, DRV8825, TMC2209) on any digital pins.  The
board runs each stepper's trapezoidal profile itself from its 100 us tick (at most one
step a tick, so up to STEPPER_MAX_SPEED steps/s each), stops a stepper within the tick
its limit switch closes in, and sends StepperDone when a stepper comes to rest.
Positions are 32-bit signed steps; speeds are steps/s, accelerations steps/s^2.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag, StepperDoneReason
from .._layout import I16, I32, U8, U16, U32
from .._messages import Event, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "StepperConfig",
    "StepperConfigReply",
    "StepperDone",
    "StepperLimit",
    "StepperLimitReply",
    "StepperMove",
    "StepperMoveReply",
    "StepperProfile",
    "StepperProfileReply",
    "StepperRead",
    "StepperReadReply",
    "StepperRun",
    "StepperRunReply",
    "StepperSetPosition",
    "StepperSetPositionReply",
    "StepperStop",
    "StepperStopReply",
]


@echo
class _Index:
    index: Annotated[int, U8]


@echo
class _Config(_Index):
    step_pin: Annotated[int, U8]
    dir_pin: Annotated[int, U8]


@reply_frame(ClassTag.STEPPER, 0x01)
class StepperConfigReply(_Config, Reply): ...


# Not idempotent: a configuration stops the stepper and zeroes its position.
@request_frame(StepperConfigReply, extension=True)
class StepperConfig(_Config, Request[StepperConfigReply]):
    """Stepper ``index`` (0-3) on a step and a direction pin (D2-D13, outputs, low).

    Stops the stepper, zeroes its position, removes its limit switches and frees pins it
    had before.  PIN_BUSY when a pin has another role (another stepper's pins too);
    VALUE_OUT_OF_RANGE for an index above 3 or one pin for both.
    """


@echo
class _Profile(_Index):
    max_speed: Annotated[int, U16]
    acceleration: Annotated[int, U32]


@reply_frame(ClassTag.STEPPER, 0x02)
class StepperProfileReply(_Profile, Reply): ...


@request_frame(StepperProfileReply, extension=True, idempotent=True)
class StepperProfile(_Profile, Request[StepperProfileReply]):
    """Top speed (1-STEPPER_MAX_SPEED steps/s) and acceleration (1-STEPPER_MAX_ACCEL
    steps/s^2) of the next moves; a move under way takes them at once."""


@echo
class _Move(_Index):
    relative: Annotated[bool, U8]


@reply_frame(ClassTag.STEPPER, 0x03)
class StepperMoveReply(_Move, Reply):
    """``target``: the absolute position the stepper now heads for."""

    target: Annotated[int, I32]


# Not idempotent when relative (a repeat moves twice as far); an absolute move is, but
# one request type carries both.
@request_frame(StepperMoveReply, extension=True)
class StepperMove(_Move, Request[StepperMoveReply]):
    """Move to ``steps`` (absolute) or by ``steps`` (relative to the current target when
    a move is under way, else to the position) with the trapezoidal profile.

    A move that reverses first decelerates to rest; StepperDone(TARGET) follows when the
    stepper stands at the target.  PIN_NOT_CONFIGURED for a stepper without pins.
    """

    steps: Annotated[int, I32]


@echo
class _Run(_Index):
    speed: Annotated[int, I16]


@reply_frame(ClassTag.STEPPER, 0x04)
class StepperRunReply(_Run, Reply): ...


@request_frame(StepperRunReply, extension=True, idempotent=True)
class StepperRun(_Run, Request[StepperRunReply]):
    """Run at ``speed`` steps/s (signed, at most STEPPER_MAX_SPEED) with no target,
    accelerating at the profile's rate; speed 0 decelerates to rest (StepperDone STOPPED)."""


@echo
class _Stop(_Index):
    immediate: Annotated[bool, U8]


@reply_frame(ClassTag.STEPPER, 0x05)
class StepperStopReply(_Stop, Reply):
    """``position`` when the request was handled (a decelerating stepper moves on)."""

    position: Annotated[int, I32]


@request_frame(StepperStopReply, extension=True, idempotent=True)
class StepperStop(_Stop, Request[StepperStopReply]):
    """Decelerate to rest (``immediate`` false) or stop at once (no further step)."""


@reply_frame(ClassTag.STEPPER, 0x06)
class StepperReadReply(_Index, Reply):
    """``speed``: steps/s now (signed); ``moving``: not at rest; ``limits``: bit 0 the
    negative-side switch is closed, bit 1 the positive-side one."""

    position: Annotated[int, I32]
    target: Annotated[int, I32]
    speed: Annotated[int, I16]
    moving: Annotated[bool, U8]
    limits: Annotated[int, U8]


@request_frame(StepperReadReply, reads_only=True, extension=True)
class StepperRead(_Index, Request[StepperReadReply]):
    """Position, target, speed and limit switches of a stepper."""


@echo
class _Position(_Index):
    position: Annotated[int, I32]


@reply_frame(ClassTag.STEPPER, 0x07)
class StepperSetPositionReply(_Position, Reply): ...


@request_frame(StepperSetPositionReply, extension=True, idempotent=True)
class StepperSetPosition(_Position, Request[StepperSetPositionReply]):
    """Call the resting stepper's position ``position`` (e.g. 0 after homing);
    STEPPER_MOVING while it moves."""


@echo
class _Limit(_Index):
    positive: Annotated[bool, U8]
    pin: Annotated[int, U8]
    active_high: Annotated[bool, U8]


@reply_frame(ClassTag.STEPPER, 0x08)
class StepperLimitReply(_Limit, Reply): ...


@request_frame(StepperLimitReply, extension=True, idempotent=True)
class StepperLimit(_Limit, Request[StepperLimitReply]):
    """A limit switch on ``pin`` (D2-D13, 0 removes it) for the stepper's negative or
    ``positive`` side: while it reads ``active_high`` the stepper takes no step that way.

    An active-low switch (to ground) gets the pin's pull-up.  The board checks it every
    tick before it steps, so a closing switch stops the stepper within one step period
    and StepperDone says LIMIT_MIN or LIMIT_MAX.
    """


@event_frame(0x06)
class StepperDone(_Index, Event):
    """A stepper came to rest: at its target, stopped, at a limit or by the failsafe."""

    reason: Annotated[StepperDoneReason, U8]
    position: Annotated[int, I32]
    timestamp_us: Annotated[int, U32]
