"""A board node's outputs: ROS commands written to pins, with freshness and failsafe.

Digital outputs take ``Bool``, servos ``Float64`` radians (0 = centre, +-pi/2 = the
ends), motors ``Float64`` speeds -1..1 and steppers ``Float64`` positions.  An output
with a ``timeout`` goes to its safe state when no command came for that long (the
freshness a ros2_control hardware interface promises) and stays there until the next
command; ``link_failsafe_ms`` arms the board's own watchdog with the same states.

Commands are *latest wins*: a command that arrives while the previous write is still on
the wire replaces any command waiting behind it, so a fast publisher never builds a
queue of stale set-points.  Kept apart from the inputs (:mod:`._inputs`) because the
two share nothing but the node they hang on.
"""

from __future__ import annotations

import logging
import math
import time
from typing import TYPE_CHECKING, Any, cast

import anyio

from ..errors import ArduinoIOError
from . import _messages as msgs
from ._config import BoardConfig, OutputConfig
from ._endpoints import Node
from ._wire import Attachment

if TYPE_CHECKING:
    from ..board import Board
    from ..board.handles import DigitalOutput, Servo
    from ..board.motors import Motor
    from ..board.steppers import Stepper
    from ..protocol.pins import DutyPwmPin, ServoPin

__all__ = ["Outputs"]

log = logging.getLogger(__name__)


class _Command:
    """One output: the newest command waiting to be written, and its freshness."""

    def __init__(self, config: OutputConfig, handle: Any) -> None:
        self.config = config
        self.handle = handle
        self.pending: float | bool | None = None
        self.wake = anyio.Event()
        #: Set by the first command: until then the output rests in its safe state.
        self.first = anyio.Event()
        self.last_command = 0.0
        self.timed_out = False
        self.commands = 0

    def offer(self, value: float | bool) -> None:
        self.pending = value
        self.last_command = time.monotonic()
        self.commands += 1
        self.wake.set()
        self.first.set()


class Outputs:
    """The output half of :class:`~._bridge.BoardNode` (a mixin: the node owns the state)."""

    config: BoardConfig
    board: Board
    node: Node
    outputs: list[_Command]
    command_errors: int

    async def _set_up_output(self, config: OutputConfig) -> _Command:
        # The configuration checked each pin against Table III: the casts restate that.
        handle: DigitalOutput | Motor | Servo | Stepper
        if config.kind == "stepper":
            assert config.direction is not None
            handle = await self.board.stepper(
                step=config.pin,
                dir=config.direction,
                max_speed=config.max_speed,
                acceleration=config.acceleration,
            )
            ros_type = msgs.FLOAT64
        elif config.kind == "bool":
            handle = await self.board.digital_output(config.pin, initial=bool(config.safe))
            ros_type = msgs.BOOL
        elif config.kind == "motor":
            assert config.direction is not None
            pwm = cast("DutyPwmPin", config.pin)
            handle = await self.board.motor(pwm, config.direction, config.direction2)
            ros_type = msgs.FLOAT64
        else:
            handle = await self.board.servo(cast("ServoPin", config.pin))
            if config.safe is not None:
                await handle.set_angle(_degrees(float(config.safe)))
            ros_type = msgs.FLOAT64
        command = _Command(config, handle)

        def on_message(message: Any, attachment: Attachment | None) -> None:
            command.offer(message.data)

        self.node.subscribe(config.topic, ros_type, on_message)
        return command

    async def _arm_link_failsafe(self, timeout_ms: int) -> None:
        """Arm the board's watchdog with every output's safe state (the same states the
        command timeout applies): a dead bridge or a pulled cable makes them safe too."""
        states: dict[Any, bool | float] = {}
        for command in self.outputs:
            safe = command.config.safe
            if command.config.kind == "bool":
                states[command.handle] = bool(safe)
            elif command.config.kind == "motor":
                states[command.handle] = 0.0  # a motor's failsafe state is stopped
            elif command.config.kind == "stepper":
                continue  # the board's failsafe stops every stepper by itself
            else:  # servo: the safe angle's pulse width, or no pulses
                servo = command.handle
                degrees = None if safe is None else _degrees(float(safe))
                states[servo] = (
                    0
                    if degrees is None
                    else round(servo.min_us + (servo.max_us - servo.min_us) * degrees / 180)
                )
        await self.board.arm_failsafe(timeout_ms, states)

    async def _write_commands(self, command: _Command) -> None:
        while True:
            await command.wake.wait()
            command.wake = anyio.Event()
            value, command.pending = command.pending, None
            if value is None:
                continue
            command.timed_out = False
            await self._write(command, value)

    async def _write(self, command: _Command, value: float | bool | None) -> None:
        """Write ``value`` (None: a servo's safe state without pulses) to the output."""
        try:
            if command.config.kind == "bool":
                await command.handle.write(bool(value))
            elif command.config.kind == "motor":
                await command.handle.set_speed(float(value or 0.0))
            elif command.config.kind == "stepper":
                await self._move_stepper(command, value)
            elif value is None:
                await command.handle.stop()
            else:
                await command.handle.set_angle(_degrees(float(value)))
        except (ArduinoIOError, ValueError) as exc:
            self.command_errors += 1
            log.warning(
                "%s: %s <- %r failed: %s", self.config.name, command.config.topic, value, exc
            )

    async def _move_stepper(self, command: _Command, value: float | bool | None) -> None:
        """A position target (radians with steps_per_rev, else steps); None: the safe
        state, an immediate stop (what the board's failsafe does to a stepper)."""
        stepper = command.handle
        if value is None:
            await stepper.stop(immediate=True)
            return
        per_rev = command.config.steps_per_rev
        target = float(value) * per_rev / (2 * math.pi) if per_rev else float(value)
        if not math.isfinite(target) or abs(target) >= 2**31:
            raise ValueError(f"{value!r} is not a stepper position")
        await stepper.move_to(round(target))

    async def _watch_freshness(self, command: _Command) -> None:
        timeout = command.config.timeout
        assert timeout is not None
        await command.first.wait()
        while True:
            left = command.last_command + timeout - time.monotonic()
            if left > 0:
                await anyio.sleep(left)
                continue
            if not command.timed_out:
                command.timed_out = True
                log.warning(
                    "%s: no command on %s for %.3f s: safe state %r",
                    self.config.name,
                    command.config.topic,
                    timeout,
                    command.config.safe,
                )
                await self._write(command, command.config.safe)
            await anyio.sleep(timeout)


def _degrees(radians: float) -> float:
    """Servo radians (0 = centre) -> the 0-180 degrees ``set_angle`` takes."""
    return 90.0 + math.degrees(radians)
