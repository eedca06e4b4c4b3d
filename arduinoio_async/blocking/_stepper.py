"""The blocking twin of :class:`~arduinoio_async.board.steppers.Stepper`
(``BlockingBoard.stepper``).

Apart from :mod:`._handles` by idea: each method runs the async one through the board's
portal, exactly as the other blocking handles do.
"""

from __future__ import annotations

from typing import Any

from ..board.steppers import LimitSwitch, Stepper, StepperState
from ..protocol.pins import DigitalPin
from ._handles import Runner

__all__ = ["BlockingStepper"]


class BlockingStepper:
    """Blocking :class:`~arduinoio_async.board.steppers.Stepper`: moves, runs, stops, homing."""

    def __init__(self, runner: Runner, handle: Stepper) -> None:
        self._runner = runner
        self.handle = handle

    def __repr__(self) -> str:
        return f"<blocking {self.handle!r}>"

    def _call(self, func: Any, *args: Any) -> Any:
        return self._runner.call(func, *args)

    def set_profile(self, max_speed: int, acceleration: int) -> None:
        """Top speed (steps/s) and acceleration (steps/s^2)."""
        self._call(self.handle.set_profile, max_speed, acceleration)

    def move_to(self, position: int, *, wait: bool = True, timeout: float | None = None) -> int:
        """Move to ``position``; waits until it rests unless ``wait`` is False; returns the
        position then (or the target when not waiting)."""
        target: int = self._call(self.handle.move_to, position)
        return self.wait(timeout).position if wait else target

    def move_by(self, steps: int, *, wait: bool = True, timeout: float | None = None) -> int:
        """Move by ``steps``; as :meth:`move_to`."""
        target: int = self._call(self.handle.move_by, steps)
        return self.wait(timeout).position if wait else target

    def run(self, speed: int) -> None:
        """Run at ``speed`` steps/s (signed); 0 decelerates to rest."""
        self._call(self.handle.run, speed)

    def stop(self, *, immediate: bool = False) -> int:
        """Decelerate to rest (or stop at once); returns the position when asked."""
        position: int = self._runner.call(lambda: self.handle.stop(immediate=immediate))
        return position

    def wait(self, timeout: float | None = None) -> StepperState:
        """Block until the stepper rests; its state then."""
        state: StepperState = self._runner.call(lambda: self.handle.wait(timeout))
        return state

    def read(self) -> StepperState:
        """Position, target, speed and limit switches now."""
        state: StepperState = self._call(self.handle.read)
        return state

    def position(self) -> int:
        """The position now (steps)."""
        return self.read().position

    def set_position(self, position: int) -> None:
        """Call the resting stepper's position ``position``."""
        self._call(self.handle.set_position, position)

    def limit(
        self, pin: DigitalPin, *, positive: bool = False, active_high: bool = False
    ) -> LimitSwitch:
        """Bind a limit switch to a side (see ``Stepper.limit``)."""
        switch: LimitSwitch = self._runner.call(
            lambda: self.handle.limit(pin, positive=positive, active_high=active_high)
        )
        return switch

    def home(
        self, speed: int, *, positive: bool = False, position: int = 0, timeout: float | None = None
    ) -> int:
        """Run to the side's limit switch and call that spot ``position`` (see
        ``Stepper.home``); returns the steps it ran."""
        ran: int = self._runner.call(
            lambda: self.handle.home(speed, positive=positive, position=position, timeout=timeout)
        )
        return ran

    def release(self) -> None:
        """End the stepper: it stops at once and its pins are freed."""
        self._call(self.handle.release)
