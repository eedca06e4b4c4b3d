"""The fake board's steppers: the STEPPER class (``firmware/src/stepper.c``) as a model.

The requests meet the firmware's checks in its order (slots, pins and their roles,
ranges, STEPPER_MOVING), so a robot program unit-tested on :class:`FakeBoard` meets the
same refusals.  Motion is modelled on the event loop's clock in ticks of 1 ms: the same
trapezoid (accelerate, cruise, decelerate once the steps left are no more than the
distance needed to stop), exact at the target, stopped by a closed limit switch before
its next step, and by the failsafe; StepperDone goes out as on the board.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import anyio

from .. import protocol as p
from ..protocol.pins import Function
from ._peripherals import PinModel, has

__all__ = ["FakeSteppers"]

E = p.ErrorCode
R = p.StepperDoneReason
_TICK_S = 0.001


@dataclass
class _Stepper:
    step: int
    dir_pin: int
    #: side (0 negative, 1 positive) -> (pin, active_high)
    limits: dict[int, tuple[int, bool]] = field(default_factory=dict)
    position: int = 0
    target: int = 0
    mode: str = "idle"  # idle | move | run | stopping
    direction: int = -1
    speed: float = 0.0  # steps/s, >= 0
    max_speed: float = 1000.0
    acceleration: float = 1000.0
    run_speed: int = 0
    phase: float = 0.0

    def pins(self) -> set[int]:
        return {self.step, self.dir_pin} | {pin for pin, _ in self.limits.values()}


class _Board(Protocol):
    """What the steppers use of the fake board (read at use: a reboot makes new pins)."""

    _pins: dict[int, PinModel]
    levels: list[bool]
    _driven: set[int]
    _booted: float

    async def push(self, frame: p.Frame) -> None: ...

    def _mask(self, function: Function) -> int: ...


class FakeSteppers:
    """Up to STEPPER_COUNT steppers of a fake board (``board``: its pins, levels, clock,
    and where board-initiated frames go)."""

    def __init__(self, board: _Board) -> None:
        self._board = board
        self.slots: list[_Stepper | None] = [None] * p.STEPPER_COUNT
        #: Pulses "sent" per step pin, for a test's assertions.
        self.steps_out: dict[int, int] = {}
        self._wake = anyio.Event()
        self._outbox: list[p.Frame] = []

    @property
    def _pins(self) -> dict[int, PinModel]:
        return self._board._pins

    @property
    def _levels(self) -> list[bool]:
        return self._board.levels

    @property
    def _driven(self) -> set[int]:
        return self._board._driven

    def handlers(self) -> dict[type[Any], Callable[[Any], p.Frame]]:
        return {
            p.StepperConfig: self._config,
            p.StepperProfile: self._profile,
            p.StepperMove: self._move,
            p.StepperRun: self._run,
            p.StepperStop: self._stop,
            p.StepperRead: self._read,
            p.StepperSetPosition: self._set_position,
            p.StepperLimit: self._limit,
        }

    def positions(self) -> Sequence[int]:
        """The i32 positions of the slots (0 without a stepper): a stream sample's."""
        return [s.position if s else 0 for s in self.slots]

    # ---- requests ---------------------------------------------------------------------

    @staticmethod
    def _error(request: p.Frame, code: p.ErrorCode) -> p.ErrorReply:
        return p.ErrorReply(request.LAYOUT.class_tag, request.LAYOUT.descriptor, code)

    def _slot(self, request: Any) -> _Stepper | p.ErrorReply:
        if request.index >= p.STEPPER_COUNT:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        slot = self.slots[request.index]
        return slot if slot is not None else self._error(request, E.PIN_NOT_CONFIGURED)

    def _owner(self, pin: int) -> tuple[int, str] | None:
        for index, slot in enumerate(self.slots):
            if slot is not None and pin in (slot.step, slot.dir_pin):
                return index, "motor"
            if slot is not None and any(pin == lp for lp, _ in slot.limits.values()):
                return index, "limit"
        return None

    def _claim(self, index: int, pin: int, capable: Function, use: str) -> p.ErrorCode | None:
        if not has(self._board._mask(capable), pin):
            return E.PIN_NOT_CAPABLE
        role = self._pins[pin].role
        if role not in ("free", "stepper"):
            return E.PIN_BUSY
        if role == "stepper" and self._owner(pin) != (index, use):
            return E.PIN_BUSY
        return None

    def _free(self, pin: int) -> None:
        self._pins[pin] = PinModel()

    def _config(self, request: p.StepperConfig) -> p.Frame:
        if request.index >= p.STEPPER_COUNT or request.step_pin == request.dir_pin:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        for pin in (request.step_pin, request.dir_pin):
            error = self._claim(request.index, pin, Function.DIGITAL_OUTPUT, "motor")
            if error is not None:
                return self._error(request, error)
        old = self.slots[request.index]
        if old is not None:
            for pin in old.pins() - {request.step_pin, request.dir_pin}:
                self._free(pin)
        self.slots[request.index] = _Stepper(request.step_pin, request.dir_pin)
        for pin in (request.step_pin, request.dir_pin):
            self._pins[pin].role = "stepper"
            self._levels[pin] = False
        return p.StepperConfigReply(request.index, request.step_pin, request.dir_pin)

    def _profile(self, request: p.StepperProfile) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        if not (
            1 <= request.max_speed <= p.STEPPER_MAX_SPEED
            and 1 <= request.acceleration <= p.STEPPER_MAX_ACCEL
        ):
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        slot.max_speed, slot.acceleration = request.max_speed, request.acceleration
        return p.StepperProfileReply(request.index, request.max_speed, request.acceleration)

    def _start(self, slot: _Stepper, mode: str) -> None:
        if slot.mode == "idle":
            slot.phase = 0.0
        slot.mode = mode
        self._wake.set()

    def _move(self, request: p.StepperMove) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        base = (slot.target if slot.mode == "move" else slot.position) if request.relative else 0
        target = (base + request.steps + 2**31) % 2**32 - 2**31
        slot.target = target
        self._start(slot, "move")
        return p.StepperMoveReply(request.index, request.relative, target)

    def _run(self, request: p.StepperRun) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        if abs(request.speed) > p.STEPPER_MAX_SPEED:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        slot.run_speed = request.speed
        self._start(slot, "run")
        return p.StepperRunReply(request.index, request.speed)

    def _stop(self, request: p.StepperStop) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        if request.immediate and slot.mode != "idle":
            self._halt(request.index, slot, R.STOPPED)
        elif slot.mode != "idle":
            slot.mode = "stopping"
        return p.StepperStopReply(request.index, request.immediate, slot.position)

    def _limit_closed(self, slot: _Stepper, side: int) -> bool:
        if side not in slot.limits:
            return False
        pin, active_high = slot.limits[side]
        return self._levels[pin] == active_high

    def _read(self, request: p.StepperRead) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        target = slot.target if slot.mode == "move" else slot.position
        limits = self._limit_closed(slot, 0) | self._limit_closed(slot, 1) << 1
        speed = round(slot.speed) * slot.direction
        moving = slot.mode != "idle"
        return p.StepperReadReply(request.index, slot.position, target, speed, moving, limits)

    def _set_position(self, request: p.StepperSetPosition) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        if slot.mode != "idle":
            return self._error(request, E.STEPPER_MOVING)
        slot.position = slot.target = request.position
        return p.StepperSetPositionReply(request.index, request.position)

    def _limit(self, request: p.StepperLimit) -> p.Frame:
        slot = self._slot(request)
        if isinstance(slot, p.ErrorReply):
            return slot
        pin, side = request.pin, int(request.positive)
        if pin:
            error = self._claim(request.index, pin, Function.DIGITAL_INPUT, "limit")
            if error is not None:
                return self._error(request, error)
        old = slot.limits.pop(side, None)
        if (
            old is not None
            and old[0] != pin
            and all(lp != old[0] for lp, _ in slot.limits.values())
        ):
            self._free(old[0])
        if pin:
            slot.limits[side] = (pin, request.active_high)
            self._pins[pin].role = "stepper"
            if not request.active_high and pin not in self._driven:
                self._levels[pin] = True  # nothing attached: the pull-up wins
        return p.StepperLimitReply(request.index, request.positive, pin, request.active_high)

    # ---- the board's side ---------------------------------------------------------------

    def release(self, pin: int) -> None:
        """PIN_RELEASE of a stepper's pin: a limit goes; a step/dir pin ends the stepper."""
        owner = self._owner(pin)
        if owner is None:
            return
        index, use = owner
        slot = self.slots[index]
        assert slot is not None
        if use == "limit":
            slot.limits = {s: v for s, v in slot.limits.items() if v[0] != pin}
            return
        for other in slot.pins() - {pin}:  # it stops at once, with no StepperDone
            self._free(other)
        self.slots[index] = None

    def stop_all(self) -> None:
        """The failsafe: every stepper stops at once."""
        for index, slot in enumerate(self.slots):
            if slot is not None and slot.mode != "idle":
                self._halt(index, slot, R.FAILSAFE)

    def reset(self) -> None:
        self.slots = [None] * p.STEPPER_COUNT

    def _halt(self, index: int, slot: _Stepper, reason: p.StepperDoneReason) -> None:
        slot.mode, slot.speed, slot.phase = "idle", 0.0, 0.0
        slot.target = slot.position
        board_us = int((anyio.current_time() - self._board._booted) * 1_000_000) & 0xFFFFFFFF
        self._outbox.append(p.StepperDone(index, reason, slot.position, board_us))
        self._wake.set()

    async def run(self) -> None:
        """The board's tick for the steppers, while one moves; sends the events."""
        while True:
            if not any(s is not None and s.mode != "idle" for s in self.slots) and not self._outbox:
                await self._wake.wait()
                self._wake = anyio.Event()
            for index, slot in enumerate(self.slots):
                if slot is not None and slot.mode != "idle":
                    self._advance(index, slot, _TICK_S)
            while self._outbox:
                with contextlib.suppress(anyio.BrokenResourceError, anyio.ClosedResourceError):
                    await self._board.push(self._outbox.pop(0))
            await anyio.sleep(_TICK_S)

    def _advance(self, index: int, slot: _Stepper, dt: float) -> None:
        side = int(slot.direction > 0)
        if slot.speed and self._limit_closed(slot, side):
            self._halt(index, slot, R.LIMIT_MAX if side else R.LIMIT_MIN)
            return
        want, top, slow = slot.direction, slot.max_speed, True
        if slot.mode == "move":
            left = slot.target - slot.position
            if not left and not slot.speed:
                self._halt(index, slot, R.TARGET)
                return
            want = -1 if left < 0 else 1
            stopping_distance = slot.speed**2 / (2 * slot.acceleration)
            slow = want != slot.direction or abs(left) <= stopping_distance
        elif slot.mode == "run":
            want, top = (
                (1 if slot.run_speed > 0 else -1) if slot.run_speed else slot.direction,
                abs(slot.run_speed),
            )
            slow = want != slot.direction or not top
        if not slot.speed:
            if slot.mode == "stopping" or (slot.mode == "run" and not top):
                self._halt(index, slot, R.STOPPED)
                return
            if want != slot.direction:
                slot.direction = want
                self._levels[slot.dir_pin] = want > 0
                return
            slow = False
        gain = slot.acceleration * dt
        if slow:
            floor = (
                (2 * slot.acceleration) ** 0.5
                if slot.mode == "move" and want == slot.direction
                else 0
            )
            slot.speed = max(slot.speed - gain, min(floor, top))
        else:
            slot.speed = (
                min(slot.speed + gain, top) if slot.speed < top else max(slot.speed - gain, top)
            )
        slot.phase += slot.speed * dt
        while slot.phase >= 1:
            if self._limit_closed(slot, side):
                self._halt(index, slot, R.LIMIT_MAX if side else R.LIMIT_MIN)
                return
            slot.phase -= 1
            slot.position += slot.direction
            self.steps_out[slot.step] = self.steps_out.get(slot.step, 0) + 1
            if slot.mode == "move" and slot.position == slot.target:
                self._halt(index, slot, R.TARGET)
                return
