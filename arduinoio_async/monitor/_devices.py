"""Devices that span pins or run on the board by themselves, as the monitor page shows them.

A quadrature encoder (two pins, a count the board keeps), a DC motor (a PWM pin and
direction pins), a stepper (a motion the board runs), a sonar or an IMU is not one pin
with one level, so the panel's per-pin table cannot show it.  A :class:`DeviceView` keeps
one kind of device: the page's controls for it (set one up on chosen pins, reset it) and
its rows, read from the board every :data:`READ_INTERVAL` with one small request per
device, so the panel tells the browsers only when a row changed.  The panel holds a list
of views and knows nothing of the kinds.

Views read only the devices the board's role table holds (set up from the page, or by a
robot program that embeds the monitor); a class the board's firmware image leaves out
(docs: firmware profiles) shows as "not in this firmware" and refuses set-up with the
library's :class:`~arduinoio_async.errors.FirmwareFeatureError`.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Mapping
from typing import TYPE_CHECKING, Any

import anyio

from .. import protocol as p
from ..board.encoders import Encoder, EncoderState, encoder_mode
from ..board.motors import Motor
from ..errors import ArduinoIOError, UsageError
from ..protocol.pins import DigitalPin

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["READ_INTERVAL", "DeviceView", "EncoderView", "MotorView"]

logger = logging.getLogger(__name__)

#: Seconds between two reads of a view's devices.
READ_INTERVAL = 0.2

Action = Callable[[Mapping[str, Any]], Awaitable[object]]


class DeviceView:
    """One kind of device on a monitored board: its rows for the page and its controls.

    A subclass names its ``key`` (the snapshot's field), the ``feature`` its class needs,
    and implements :meth:`read_rows` and :meth:`actions`.
    """

    key = ""
    feature = p.Feature.NONE

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        self.board = board
        self.rows: list[dict[str, object]] = []
        self._on_change = on_change

    @property
    def supported(self) -> bool:
        """Whether the board's firmware image holds this class."""
        return bool(self.board.capabilities.features & self.feature)

    def describe(self) -> dict[str, object]:
        """The snapshot's field: the rows, or why there are none."""
        return {"supported": self.supported, "rows": self.rows}

    def actions(self) -> dict[str, Action]:
        """The page's operations on this kind of device, by operation name."""
        return {}

    async def read_rows(self) -> list[dict[str, object]]:
        """One row per device the board holds now."""
        raise NotImplementedError

    async def read(self) -> None:
        """Read every device once; the panel hears of a change."""
        try:
            rows = await self.read_rows()
        except ArduinoIOError as exc:
            logger.debug("%s not read: %s", self.key, exc)
            return
        if rows != self.rows:
            self.rows = rows
            self._on_change()

    async def run(self) -> None:
        """Read the devices every READ_INTERVAL until cancelled."""
        if not self.supported:
            return
        while True:
            if self.board.connected:
                await self.read()
            await anyio.sleep(READ_INTERVAL)


class EncoderView(DeviceView):
    """Quadrature encoders: count, velocity (counts/s between two reads, timed by the
    board's edge stamps) and invalid transitions; set up and reset from the page."""

    key = "encoders"
    feature = p.Feature.ENCODER

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        super().__init__(board, on_change=on_change)
        self._last: dict[int, EncoderState] = {}

    def encoders(self) -> list[Encoder]:
        """The encoders in the board's role table, by slot."""
        found = {
            claim.handle.slot: claim.handle
            for claim in self.board.roles.values()
            if isinstance(claim.handle, Encoder) and not claim.handle.released
        }
        return [found[slot] for slot in sorted(found)]

    async def read_rows(self) -> list[dict[str, object]]:
        rows: list[dict[str, object]] = []
        for encoder in self.encoders():
            state = await encoder.read()
            earlier = self._last.get(encoder.slot)
            self._last[encoder.slot] = state
            velocity = state.velocity_since(earlier) if earlier is not None else 0.0
            rows.append(
                {
                    "slot": encoder.slot,
                    "pins": f"{encoder.pin.name}/{encoder.pin_b.name}",
                    "count": state.count,
                    "velocity": round(velocity, 1),
                    "invalid": state.invalid,
                }
            )
        return rows

    def actions(self) -> dict[str, Action]:
        return {"encoder": self._set_up, "encoder_reset": self._reset}

    async def _set_up(self, args: Mapping[str, Any]) -> int:
        """``{"a": "D4", "b": "D5", "mode": "x4"}``: a new encoder; answers its slot."""
        a, b = _digital(args, "a"), _digital(args, "b")
        encoder = await self.board.encoder(a, b, mode=encoder_mode(str(args.get("mode", "x4"))))
        await self.read()
        return encoder.slot

    async def _reset(self, args: Mapping[str, Any]) -> int:
        """``{"slot": 0}``: the count back to 0; answers the count it had."""
        slot = int(args["slot"])
        for encoder in self.encoders():
            if encoder.slot == slot:
                before = await encoder.reset()
                self._last.pop(slot, None)
                await self.read()
                return before.count
        raise UsageError(f"no encoder in slot {slot} on this page")


def _digital(args: Mapping[str, Any], name: str) -> DigitalPin:
    try:
        return DigitalPin[str(args[name])]
    except KeyError:
        raise UsageError(f"{name} must be a digital pin name such as D4") from None


class MotorView(DeviceView):
    """DC motors set up from the page: signed speed, brake and coast (``board.motor``,
    ``board.motor_2pwm``).  A motor is a pair of roles (its PWM pin and its direction
    pins) with no record of its own on the board, so the view lists the motors made
    here; a robot program's motors show as their pins' duty and output roles."""

    key = "motors"
    feature = p.Feature.DUTY_PWM

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        super().__init__(board, on_change=on_change)
        self.motors: list[Motor] = []

    def _live(self) -> list[Motor]:
        """The motors whose pins still hold their roles (a release or another role ends one)."""
        self.motors = [
            m
            for m in self.motors
            if all(not h.released and h.pin in self.board.roles for h in m.speed_pins)
        ]
        return self.motors

    async def read_rows(self) -> list[dict[str, object]]:
        return [
            {
                "index": index,
                "pins": "/".join(h.pin.name for h in (*motor.speed_pins, *motor.directions)),
                "speed": round(motor.speed, 3),
                "state": motor.state,
            }
            for index, motor in enumerate(self._live())
        ]

    def actions(self) -> dict[str, Action]:
        return {
            "motor": self._set_up,
            "motor_speed": self._speed,
            "motor_brake": self._brake,
            "motor_coast": self._coast,
        }

    async def _set_up(self, args: Mapping[str, Any]) -> int:
        """``{"kind": "dir", "pwm": "D9", "in1": "D7", "in2": "D8"}`` (``in2`` optional) or
        ``{"kind": "2pwm", "in1": "D9", "in2": "D10"}``; answers the motor's index."""
        kind = str(args.get("kind", "dir"))
        if kind == "2pwm":
            motor = await self.board.motor_2pwm(
                _digital(args, "in1"),  # type: ignore[arg-type]  # checked by the board method
                _digital(args, "in2"),  # type: ignore[arg-type]
            )
        elif kind == "dir":
            in2 = _digital(args, "in2") if args.get("in2") else None
            motor = await self.board.motor(
                _digital(args, "pwm"),  # type: ignore[arg-type]  # checked by the board method
                _digital(args, "in1"),
                in2,
            )
        else:
            raise UsageError(f"motor kind is 'dir' (PWM + direction) or '2pwm', not {kind!r}")
        self._live().append(motor)
        await self.read()
        return len(self.motors) - 1

    def _motor(self, args: Mapping[str, Any]) -> Motor:
        index = int(args["index"])
        motors = self._live()
        if not 0 <= index < len(motors):
            raise UsageError(f"no motor {index} on this page")
        return motors[index]

    async def _speed(self, args: Mapping[str, Any]) -> None:
        """``{"index": 0, "speed": -0.4}``: signed speed, -1..1."""
        await self._motor(args).set_speed(float(args["speed"]))
        await self.read()

    async def _brake(self, args: Mapping[str, Any]) -> None:
        await self._motor(args).brake()
        await self.read()

    async def _coast(self, args: Mapping[str, Any]) -> None:
        await self._motor(args).coast()
        await self.read()
