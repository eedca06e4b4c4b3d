"""Stepper motors behind step/dir drivers, and their limit switches.

A :class:`Stepper` is one of the board's four stepper slots on a step and a direction pin
(A4988, DRV8825, TMC2209: any digital pins).  The board runs the motion itself: a
trapezoidal profile (top speed, acceleration) from its 100 us tick, at most one step a
tick (10,000 steps/s a stepper), exact at the target; a limit switch bound to a side
stops the stepper inside the board before its next step, and every stepper stops when
the failsafe trips.  The host only sends targets and reads positions, so a loaded host
or a slow link never costs a step.

The pins are recorded in the board's role table like any handle's
(:class:`StepperPin`, :class:`LimitSwitch`), so a pin another role holds is refused
before anything is sent, with words that name the stepper (``PinRoleError``: "D3 is in
use as stepper 0's direction pin; ..."), and a reset replays the stepper's set-up (its
position starts at 0 again: the board's RAM was lost).

``StepperDone`` events (the board pushes one when a stepper comes to rest, saying why)
wake :meth:`Stepper.wait`, which confirms with a read that the stepper is at rest, so a
late event of an earlier motion can never end the wait of a new one.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, NamedTuple

import anyio

from .. import protocol as p
from ..errors import UsageError, ValueRangeError
from ..protocol.pins import DigitalPin, Function
from .handles import PinHandle

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["LimitSwitch", "Stepper", "StepperPin", "StepperState"]

logger = logging.getLogger(__name__)

#: How long :meth:`Stepper.wait` trusts the event alone before it reads the board again
#: (only a lost event or a reconnect makes the read find the stepper at rest first).
_RECHECK_S = 0.5


class StepperState(NamedTuple):
    """A stepper's state as the board reports it (``StepperRead``)."""

    position: int
    #: The move's target, or the position when no move is under way.
    target: int
    #: Steps/s now, signed.
    speed: int
    moving: bool
    #: Whether the negative-side / positive-side limit switch is closed now.
    limit_min: bool
    limit_max: bool


class StepperPin(PinHandle):
    """A step or direction pin of a stepper (its role in the board's role table)."""

    def __init__(self, board: BoardCore, pin: DigitalPin, role: str) -> None:
        super().__init__(board, pin)
        self.ROLE = role
        self.stepper_index = -1


class LimitSwitch(PinHandle):
    """A limit switch input bound to a side of a stepper."""

    def __init__(self, board: BoardCore, pin: DigitalPin, role: str) -> None:
        super().__init__(board, pin)
        self.ROLE = role


def check_speed(speed: int, what: str, *, signed: bool = False) -> int:
    """A speed in whole steps/s within the board's range, else ValueRangeError."""
    low = -p.STEPPER_MAX_SPEED if signed else 1
    if (
        isinstance(speed, bool)
        or not isinstance(speed, int)
        or not low <= speed <= p.STEPPER_MAX_SPEED
    ):
        raise ValueRangeError(what, speed, f"whole steps/s, {low}-{p.STEPPER_MAX_SPEED}")
    return speed


def check_acceleration(acceleration: int) -> int:
    if (
        isinstance(acceleration, bool)
        or not isinstance(acceleration, int)
        or not 1 <= acceleration <= p.STEPPER_MAX_ACCEL
    ):
        raise ValueRangeError(
            "stepper acceleration", acceleration, f"whole steps/s^2, 1-{p.STEPPER_MAX_ACCEL}"
        )
    return acceleration


def check_steps(steps: int) -> int:
    if isinstance(steps, bool) or not isinstance(steps, int) or not -(2**31) <= steps < 2**31:
        raise ValueRangeError("stepper position", steps, "a 32-bit signed number of steps")
    return steps


class Stepper:
    """One stepper slot of the board (``board.stepper(step=D2, dir=D3)``)."""

    def __init__(
        self, board: BoardCore, index: int, step: StepperPin, direction: StepperPin
    ) -> None:
        self.board = board
        self.index = index
        self.step_pin = step
        self.dir_pin = direction
        #: Side (False = negative, True = positive) -> its switch.
        self.limits: dict[bool, LimitSwitch] = {}
        #: The latest StepperDone the board sent for this stepper (None before any).
        self.last_done: p.StepperDone | None = None
        self.max_speed = 0
        self.acceleration = 0
        self._arrived = anyio.Event()
        self._unsubscribe = board.link.subscribe(self._on_event)

    def __repr__(self) -> str:
        return (
            f"<Stepper {self.index} step={self.step_pin.pin.name} dir={self.dir_pin.pin.name} "
            f"on {self.board}>"
        )

    @property
    def released(self) -> bool:
        """Whether the stepper's pins were released (it can no longer move)."""
        return self.step_pin.released or self.dir_pin.released

    def _check(self) -> None:
        self.step_pin.check_usable()
        self.dir_pin.check_usable()

    def _on_event(self, event: p.Event) -> None:
        if isinstance(event, p.StepperDone) and event.index == self.index:
            self.last_done = event
            self._arrived.set()

    # ---- motion --------------------------------------------------------------------------

    async def set_profile(self, max_speed: int, acceleration: int) -> None:
        """Top speed (1-10,000 steps/s) and acceleration (steps/s^2) of the moves; a move
        under way takes them at once.  Recorded, so a reset restores them."""
        self._check()
        request = p.StepperProfile(
            self.index,
            check_speed(max_speed, "stepper top speed"),
            check_acceleration(acceleration),
        )
        await self.board.request(request)
        self.max_speed, self.acceleration = max_speed, acceleration
        self.board.roles.amend(self.dir_pin, request)

    async def move_to(self, position: int) -> int:
        """Head for ``position`` (absolute steps) with the profile; returns the target.
        Does not wait: :meth:`wait` does (or ``await stepper.move_to(x, ...)`` then
        ``await stepper.wait()``)."""
        self._check()
        reply = await self.board.request(p.StepperMove(self.index, False, check_steps(position)))
        return reply.target

    async def move_by(self, steps: int) -> int:
        """Move ``steps`` from the current target (or the position when at rest); returns
        the new absolute target."""
        self._check()
        reply = await self.board.request(p.StepperMove(self.index, True, check_steps(steps)))
        return reply.target

    async def run(self, speed: int) -> None:
        """Run at ``speed`` steps/s (signed) with no target, accelerating at the profile's
        rate; 0 decelerates to rest."""
        self._check()
        await self.board.request(
            p.StepperRun(self.index, check_speed(speed, "run speed", signed=True))
        )

    async def stop(self, *, immediate: bool = False) -> int:
        """Decelerate to rest (or stop before the next step if ``immediate``); returns the
        position when the board got the request."""
        self._check()
        reply = await self.board.request(p.StepperStop(self.index, immediate))
        return reply.position

    async def read(self) -> StepperState:
        """Position, target, speed and limit switches now."""
        self._check()
        r = await self.board.request(p.StepperRead(self.index))
        return StepperState(
            r.position, r.target, r.speed, r.moving, bool(r.limits & 1), bool(r.limits & 2)
        )

    async def position(self) -> int:
        """The position now (steps)."""
        return (await self.read()).position

    async def set_position(self, position: int) -> None:
        """Call the resting stepper's position ``position`` (StepperMovingError while it
        moves)."""
        self._check()
        await self.board.request(p.StepperSetPosition(self.index, check_steps(position)))

    async def wait(self, timeout: float | None = None) -> StepperState:
        """Wait until the stepper is at rest; returns its state then (``last_done`` says
        why it stopped).  Woken by the board's StepperDone event, confirmed by a read."""
        with anyio.fail_after(timeout):
            while True:
                self._arrived = anyio.Event()
                state = await self.read()
                if not state.moving:
                    return state
                with anyio.move_on_after(_RECHECK_S):
                    await self._arrived.wait()

    async def move_to_and_wait(self, position: int, timeout: float | None = None) -> StepperState:
        """:meth:`move_to`, then :meth:`wait`."""
        await self.move_to(position)
        return await self.wait(timeout)

    # ---- limit switches and homing ---------------------------------------------------------

    async def limit(
        self, pin: DigitalPin, *, positive: bool = False, active_high: bool = False
    ) -> LimitSwitch:
        """Bind a limit switch on ``pin`` to the negative side (or ``positive``): while it
        reads closed the board lets the stepper take no step that way, and a closing
        switch stops it within one step period (StepperDone LIMIT_MIN/LIMIT_MAX).

        ``active_high`` False (the default) is a switch to ground: the pin gets its
        pull-up and reads low when closed.  One switch may serve both sides.
        """
        self._check()
        side = "positive" if positive else "negative"
        mine = [s for s in self.limits.values() if s.pin == pin]
        switch = (
            mine[0]
            if mine
            else LimitSwitch(self.board, pin, f"stepper {self.index}'s {side} limit switch")
        )
        if not mine:  # checked as any new input's pin is (Table III, one role per pin)
            self.board.model.require(pin, Function.DIGITAL_INPUT)
            self.board.roles.check_free(switch)
        old = self.limits.get(positive)
        request = p.StepperLimit(self.index, positive, int(pin), active_high)
        if mine:
            await self.board.request(request)
        else:
            await self.board.set_up(switch, request)
        if old is not None and old is not switch and old not in self.limits.values():
            self.board.roles.release(old.pin)
        self.limits[positive] = switch
        return switch

    async def home(
        self, speed: int, *, positive: bool = False, position: int = 0, timeout: float | None = None
    ) -> int:
        """Run toward the limit switch of a side until it stops the stepper there, then call
        that spot ``position``; returns the steps it ran.

        Raises UsageError without a switch on that side, and HomingError (a UsageError)
        if the stepper came to rest for another reason (a STOP, the failsafe).
        """
        if positive not in self.limits:
            side = "positive" if positive else "negative"
            raise UsageError(f"stepper {self.index} has no {side} limit switch to home against")
        speed = abs(check_speed(speed, "homing speed"))
        start = await self.read()
        if not (start.limit_max if positive else start.limit_min):
            await self.run(speed if positive else -speed)
            end = await self.wait(timeout)
            want = p.StepperDoneReason.LIMIT_MAX if positive else p.StepperDoneReason.LIMIT_MIN
            done = self.last_done
            if done is None or done.reason is not want or done.position != end.position:
                raise HomingError(self.index, done)
        else:
            end = start
        await self.set_position(position)
        return abs(end.position - start.position)

    async def release(self) -> None:
        """End the stepper: it stops at once and its pins (limit switches too) are freed."""
        self._check()
        self._unsubscribe()
        await self.board.release(self.step_pin.pin)
        for pin in (self.dir_pin.pin, *(s.pin for s in self.limits.values())):
            self.board.roles.release(pin)  # the board freed them with the step pin


class HomingError(UsageError):
    """Homing ended without the limit switch stopping the stepper."""

    def __init__(self, index: int, done: p.StepperDone | None) -> None:
        why = "no StepperDone arrived" if done is None else f"it stopped: {done.reason.name}"
        super().__init__(f"stepper {index} did not reach its limit switch ({why})")
        self.index = index
        self.done = done
