"""One board as the monitor page sees it: its state, its live activity, and its controls.

A :class:`BoardPanel` is built around a :class:`~arduinoio_async.board.Board` it is handed
(opened on a port, found by the manager by ID, or later a remote board): it never opens
anything itself.  The pin roles it shows are the board's own records, so roles set up by
a robot program that embeds the monitor show up too, and every control goes through the
board's typed handles with their checks; a refused operation comes back to the page as
the library's error message.

Live data arrives from its sources as :class:`~._sources.Activity` and is folded into a
batch that the hub sends to the browsers a few times a second (the browser never polls):
the digital inputs' levels and edges from the board's change events
(:class:`~._changes.ChangeSource`), everything else from the firmware-timed stream
(:class:`~._sources.StreamSource`).  A pin's level is shown only while a source knows it.
The board latches edges of its inputs only; an output's edges are counted from its
levels in the stream (an output toggled twice within one period shows no edge).

Pins the board has a role for and the panel has no handle for (set up by an earlier
program or by another client of a served board) are shown as set elsewhere, with the
board's own word for the role (:mod:`._elsewhere`); choosing a role on the page takes
such a pin over (the board, or the server for another live client, may refuse).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import anyio

from .. import protocol as p
from ..board.handles import Counter, DigitalOutput, Gpio, I2CBus, PinHandle, PulseOutput
from ..board.motors import DutyPwm, Motor
from ..board.roles import RoleHolder
from ..errors import PinRoleError, UsageError
from ..protocol.boards import UNO_R3, BoardModel
from ..protocol.pins import UNO_DIGITAL, AnalogPin, DigitalPin, Function
from ._args import pin_arg
from ._changes import ChangeSource
from ._counts import CountSource
from ._devices import DeviceView, EncoderView, MotorView
from ._elsewhere import RolesElsewhere
from ._imu_view import ImuView
from ._rc_view import RcInputView
from ._sonar_view import SonarView
from ._sources import Activity, ActivitySource, PinKey, StreamSource
from ._spi_view import SpiView
from ._steppers import StepperView

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["ROLES", "BoardPanel", "roles_for"]

#: Bit n set for every digital pin Dn the page shows.
ALL_PINS = sum(1 << int(pin) for pin in UNO_DIGITAL)
#: Longest a role control waits for the change events of its inputs to be subscribed.
SUBSCRIBE_WAIT = 2.0
#: The event counters' pins, in the order the stream reports their counts.
COUNTER_PINS = (DigitalPin.D2, DigitalPin.D3)

#: Roles the page offers, in menu order; each pin offers those of Table III it can do.
ROLES: Mapping[str, Function | None] = {
    "free": None,
    "input": Function.DIGITAL_INPUT,
    "input_pullup": Function.DIGITAL_INPUT,
    "output": Function.DIGITAL_OUTPUT,
    "soft_pwm": Function.SOFT_PWM,
    "servo": Function.SERVO_PWM,
    "duty": Function.DUTY_PWM,
    "counter_rising": Function.COUNTER,
    "counter_falling": Function.COUNTER,
}


def roles_for(pin: DigitalPin, model: BoardModel = UNO_R3) -> list[str]:
    """The roles ``pin`` can take on a board of ``model`` (what the board described)."""
    return [
        role for role, function in ROLES.items() if function is None or model.can(pin, function)
    ]


@dataclass
class PinRole:
    """A pin's role as read back from the board's records, with its setting."""

    role: str = "free"
    #: Output level, or pulse width in us, or duty in 0.1 % (0-1000), or None.
    value: int | None = None
    handle: RoleHolder | None = None
    #: The board's role in words when it was set up elsewhere (``role`` is "elsewhere").
    elsewhere: str | None = None


def _role_of(handle: RoleHolder, config: p.Request[Any]) -> PinRole:
    if isinstance(config, p.GpioConfig):
        if config.flags & p.GpioFlags.OUTPUT:
            return PinRole("output", int(bool(config.flags & p.GpioFlags.INITIAL_HIGH)), handle)
        pull_up = bool(config.flags & p.GpioFlags.PULL_UP)
        return PinRole("input_pullup" if pull_up else "input", None, handle)
    if isinstance(config, p.PwmConfig):
        kind = "servo" if config.pin in (DigitalPin.D9, DigitalPin.D10) else "soft_pwm"
        return PinRole(kind, config.pulse_us, handle)
    if isinstance(config, p.PwmDutyConfig):
        return PinRole("duty", round(config.duty * 1000 / p.DUTY_FULL), handle)
    if isinstance(config, p.CounterConfig):
        edge = "rising" if config.edge == p.Edge.RISING else "falling"
        return PinRole(f"counter_{edge}", None, handle)
    return PinRole(handle.ROLE, None, handle)


@dataclass
class _Batch:
    """Activity gathered since the last flush to the browsers."""

    times: list[float] = field(default_factory=list)
    analog: dict[str, list[int]] = field(default_factory=dict)
    rose: int = 0
    fell: int = 0
    #: A counter's count arrived (or was cleared).
    counted: bool = False

    def __bool__(self) -> bool:
        return bool(self.times) or bool(self.rose | self.fell) or self.counted


class BoardPanel:
    """The monitor's view of one board and the controls the page may use on it."""

    def __init__(
        self,
        key: str,
        board: Board,
        *,
        period_ms: float = 20.0,
        stream: bool = True,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        self.key = key
        self.board = board
        self.stream = StreamSource(
            board, self.analog_pins, period_ms=period_ms, enabled=stream, on_change=self.changed
        )
        self.changes = ChangeSource(board, self.inputs, on_change=self.changed)
        self.counts = CountSource(board, self.counter_pins, on_change=self.changed)
        self.sources: list[ActivitySource] = [self.stream, self.changes, self.counts]
        self.elsewhere = RolesElsewhere(board, on_change=self.changed)
        #: Devices beyond one pin (encoders, motors, steppers, SPI, IMU): :mod:`._devices`.
        self.devices: list[DeviceView] = [
            EncoderView(board, on_change=self.changed),
            MotorView(board, on_change=self.changed),
            StepperView(board, on_change=self.changed),
            SpiView(board, on_change=self.changed),
            SonarView(board, on_change=self.changed),
            ImuView(board, on_change=self.changed),
            RcInputView(board, on_change=self.changed),
        ]
        #: Bit n = last known level of Dn; ``known`` says which bits a source reported.
        self.levels = 0
        self.known = 0
        #: Last count of each counter (D2, D3) from whichever source reported it last.
        self.counters: dict[DigitalPin, int] = {}
        self.analog: dict[str, int] = {}
        #: Edges seen per pin, in the page's order: the board's own digital pins.
        self.rises = dict.fromkeys(self.digital_pins(), 0)
        self.falls = dict.fromkeys(self.digital_pins(), 0)
        self.i2c: I2CBus | None = None
        self.message = ""
        self.config_changed = True
        self._batch = _Batch()
        self._notify = on_change
        self._lock = anyio.Lock()

    # ---- live data ---------------------------------------------------------------------

    def digital_pins(self) -> list[DigitalPin]:
        """The pins the page lays out: the digital pins the board described (D2-D13 on an
        Uno, D2-D53 on a Mega)."""
        return [DigitalPin(n) for n in self.board.model.pin_numbers(Function.DIGITAL_OUTPUT)]

    def analog_pins(self, *, streamed: bool = True) -> list[AnalogPin]:
        """The board's analog inputs the stream can carry (its mask is a byte: A0-A7), less
        those the I2C bus uses while it runs (A4/A5 on an Uno) unless ``streamed`` is False."""
        model, i2c = self.board.model, self.board.model.pin_numbers(Function.I2C)
        busy = set(i2c) if self.i2c is not None and streamed else set()
        numbers = [n for n in model.pin_numbers(Function.ANALOG_INPUT) if n not in busy]
        return [AnalogPin(c) for n in numbers if (c := n - model.digital_pins) < 8]

    def inputs(self) -> dict[DigitalPin, PinKey]:
        """The pins with an input role, each keyed by its handle and role (pull-up or not)."""
        return {
            pin: (id(role.handle), role.role)
            for pin, role in self.pin_roles().items()
            if role.role in ("input", "input_pullup")
        }

    def counter_pins(self) -> dict[DigitalPin, PinKey]:
        """The pins with a counter role, each keyed by its handle and role (the edge)."""
        return {
            pin: (id(role.handle), role.role)
            for pin, role in self.pin_roles().items()
            if role.role.startswith("counter_")
        }

    def on_activity(self, activity: Activity) -> None:
        batch = self._batch
        if activity.analog:
            batch.times.append(activity.time)
            for channel, value in activity.analog.items():
                batch.analog.setdefault(channel.name, []).append(value)
                self.analog[channel.name] = value
        if activity.pin_levels:
            # Change events: the source owns these pins, each edge is one event.
            mine = sum(1 << int(pin) for pin in activity.pin_levels)
            high = sum(1 << int(pin) for pin, level in activity.pin_levels.items() if level)
        else:
            # The stream: every pin except those the change events own.
            mine = ALL_PINS & ~self.changes.watched_mask
            high = activity.levels or 0
        rose, fell = activity.rose & mine, activity.fell & mine
        if activity.levels is not None:
            # The board latches no edges of outputs: count them from the levels.
            outputs = self._outputs() & mine & self.known
            rose |= outputs & high & ~self.levels
            fell |= outputs & ~high & self.levels
        if activity.levels is not None or activity.pin_levels:
            self.levels = self.levels & ~mine | high & mine
            self.known |= mine
        if rose or fell:
            batch.rose |= rose
            batch.fell |= fell
            for pin in self.rises:
                self.rises[pin] += rose >> int(pin) & 1
                self.falls[pin] += fell >> int(pin) & 1
        if activity.counters is not None:
            self.counters.update(zip(COUNTER_PINS, activity.counters, strict=True))
            batch.counted = True
        if activity.counts:
            self.counters.update(activity.counts)
            batch.counted = True
        self._notify()

    def changed(self) -> None:
        """Configuration or state changed: the page gets a fresh snapshot."""
        self.config_changed = True
        self._notify()

    def take_samples(self) -> dict[str, object] | None:
        """The activity since the previous call as one message, or None if there was none."""
        batch, self._batch = self._batch, _Batch()
        watched = self.changes.watched_mask
        # A level is known while its source runs: a pin no longer watched keeps the last
        # level the events gave only if the stream goes on reporting it.
        known = self.known & (watched | (ALL_PINS if self.stream.running else 0))
        if not batch and not known:
            return None
        return {
            "type": "samples",
            "board": self.key,
            "t": batch.times,
            "analog": batch.analog,
            "levels": self.levels & known,
            "known": known,
            "watched": watched,
            "rose": batch.rose,
            "fell": batch.fell,
            "rises": list(self.rises.values()),
            "falls": list(self.falls.values()),
            "counters": [self.counters.get(pin) for pin in COUNTER_PINS],
            "reported": sum(1 << int(pin) for pin in self.counts.reported),
            "stream": self.stream.describe(),
            "changes": self.changes.describe(),
            "counts": self.counts.describe(),
        }

    def _outputs(self) -> int:
        """Bit n set for each pin Dn that is a digital output (here or elsewhere)."""
        roles = self.pin_roles().items()
        return sum(
            1 << int(pin)
            for pin, role in roles
            if role.role == "output" or role.elsewhere == "digital output"
        )

    async def run(self) -> None:
        """Run every activity source until cancelled; a failsafe trip updates the page."""
        stop_listening = self.board.on_failsafe(lambda _board: self.changed())
        try:
            async with anyio.create_task_group() as tg:
                tg.start_soon(self.elsewhere.run)
                for device in self.devices:
                    tg.start_soon(device.run)
                for source in self.sources:
                    tg.start_soon(source.run, self.on_activity)
        finally:
            stop_listening()

    # ---- state for the page ------------------------------------------------------------------

    def pin_roles(self) -> dict[DigitalPin, PinRole]:
        roles = {pin: PinRole() for pin in self.digital_pins()}
        for pin in roles:
            words = self.elsewhere.role(pin)
            if words is not None:
                roles[pin] = PinRole("elsewhere", elsewhere=words)
        for pin, (handle, config) in self.board.roles.items():
            roles[pin] = _role_of(handle, config)
        return roles

    def snapshot(self) -> dict[str, object]:
        board = self.board
        caps = board.capabilities
        roles = self.pin_roles()
        if board.failsafe is None:
            failsafe = "off"
        elif board.failsafe_tripped:
            failsafe = "tripped"
        else:
            failsafe = f"armed ({board.failsafe.timeout_ms} ms)"
        return {
            "type": "board",
            "key": self.key,
            "id": board.board_id,
            "port": board.port,
            "connected": board.connected,
            "firmware": f"{caps.firmware_major}.{caps.firmware_minor}",
            "protocol": caps.protocol_version,
            "baud": caps.baud,
            "failsafe": failsafe,
            "failsafe_tripped": board.failsafe_tripped,
            "stream": self.stream.describe(),
            "changes": self.changes.describe(),
            "i2c": None if self.i2c is None else int(self.i2c.speed),
            "analog_pins": [pin.name for pin in self.analog_pins(streamed=False)],
            **{device.key: device.describe() for device in self.devices},
            "message": self.message,
            "pins": [
                {
                    "name": pin.name,
                    "role": roles[pin].role,
                    "value": roles[pin].value,
                    "elsewhere": roles[pin].elsewhere,
                    "roles": roles_for(pin, board.model),
                }
                for pin in self.digital_pins()
            ],
        }

    # ---- controls ----------------------------------------------------------------------------

    async def perform(self, op: str, args: Mapping[str, Any]) -> object:
        """Carry out one control from the page; returns JSON-ready data for the reply.

        Controls on one board run one at a time, in the order they arrived.
        """
        action = self._actions().get(op)
        if action is None:
            raise UsageError(f"unknown monitor operation {op!r}")
        async with self._lock:
            try:
                return await action(args)
            finally:
                self.elsewhere.refresh()
                self.changed()

    def _actions(self) -> dict[str, Callable[[Mapping[str, Any]], Any]]:
        devices = {op: act for device in self.devices for op, act in device.actions().items()}
        return devices | {
            "role": self._set_role,
            "write": self._write,
            "pulse": self._pulse,
            "duty": self._duty,
            "counter_reset": self._counter_reset,
            "i2c_read": self._i2c_read,
            "i2c_write": self._i2c_write,
            "reset": self._reset,
            "failsafe_arm": self._failsafe_arm,
            "failsafe_disarm": self._failsafe_disarm,
            "failsafe_rearm": self._failsafe_rearm,
        }

    def _handle(self, pin: DigitalPin, kind: tuple[type[PinHandle], ...], wanted: str) -> Any:
        current = self.pin_roles()[pin]
        if not isinstance(current.handle, kind):
            raise PinRoleError(pin.name, current.role, wanted)
        return current.handle

    async def _set_role(self, args: Mapping[str, Any]) -> None:
        """Give a pin a role; change events and counter reports follow at once (their
        sources' own check would notice within SUPERVISE_INTERVAL)."""
        inputs, counters = self.inputs(), self.counter_pins()
        try:
            await self._change_role(pin_arg(args), str(args["role"]))
        finally:
            if self.inputs() != inputs:
                self.changes.restart()
            if self.counter_pins() != counters:
                self.counts.restart()
        # Answer once the inputs are watched: an edge after the answer is counted.
        with anyio.move_on_after(SUBSCRIBE_WAIT):
            await self.changes.wait_watching(frozenset(self.inputs()))

    async def _change_role(self, pin: DigitalPin, role: str) -> None:
        can = roles_for(pin, self.board.model)
        if role not in can:
            raise UsageError(f"{pin.name} cannot be {role}; it can be {', '.join(can)}")
        if self.pin_roles()[pin].role != "free":
            await self.board.release(pin)
        board = self.board
        if role == "input" or role == "input_pullup":
            await board.digital_input(pin, pull_up=role == "input_pullup")
        elif role == "output":
            await board.digital_output(pin)
        elif role == "soft_pwm":
            await board.soft_pwm(pin)  # type: ignore[arg-type]  # checked by roles_for
        elif role == "servo":
            await board.servo(pin)  # type: ignore[arg-type]
        elif role == "duty":
            await board.pwm(pin)  # type: ignore[arg-type]  # the timer's default frequency
        elif role.startswith("counter_"):
            edge = p.Edge.RISING if role == "counter_rising" else p.Edge.FALLING
            await board.counter(pin, edge=edge)  # type: ignore[arg-type]

    async def _write(self, args: Mapping[str, Any]) -> None:
        pin = pin_arg(args)
        handle = self._handle(pin, (DigitalOutput, Gpio), "digital output")
        await handle.write(bool(int(args["value"])))

    async def _pulse(self, args: Mapping[str, Any]) -> None:
        pin = pin_arg(args)
        handle: PulseOutput = self._handle(pin, (PulseOutput,), "servo or software PWM")
        await handle.set_pulse(int(args["us"]))

    async def _duty(self, args: Mapping[str, Any]) -> None:
        """The duty slider: ``permille`` 0-1000 of the period."""
        pin = pin_arg(args)
        handle: DutyPwm = self._handle(pin, (DutyPwm,), "duty-cycle PWM")
        await handle.set_duty(int(args["permille"]) / 1000)

    async def _counter_reset(self, args: Mapping[str, Any]) -> int:
        pin = pin_arg(args)
        counter: Counter = self._handle(pin, (Counter,), "event counter")
        count = await counter.reset()
        self.counters[pin] = 0  # until the next report or sample
        self._batch.counted = True
        return count

    async def _bus(self, args: Mapping[str, Any]) -> I2CBus:
        speed = p.I2CSpeed.KHZ_400 if int(args.get("speed", 100)) == 400 else p.I2CSpeed.KHZ_100
        if self.i2c is None or self.i2c.speed != speed:
            first = self.i2c is None
            async with self.stream.paused():  # A4/A5 leave the stream
                self.i2c = await self.board.i2c(speed)
            if first:
                self.analog.pop("A4", None)
                self.analog.pop("A5", None)
        return self.i2c

    async def _i2c_read(self, args: Mapping[str, Any]) -> str:
        bus = await self._bus(args)
        data = await bus.read(int(args["address"]), int(args["register"]), int(args["length"]))
        return data.hex(" ")

    async def _i2c_write(self, args: Mapping[str, Any]) -> int:
        try:
            data = bytes.fromhex(str(args["data"]))
        except ValueError:
            raise UsageError(
                f"I2C data must be hex bytes like '01 ff', got {args['data']!r}"
            ) from None
        bus = await self._bus(args)
        await bus.write(int(args["address"]), int(args["register"]), data)
        return len(data)

    async def _reset(self, args: Mapping[str, Any]) -> None:
        """Reset the board, then put back every role, the I2C bus and an armed failsafe."""
        async with self.stream.paused(), self.changes.paused(), self.counts.paused():
            await self.board.reset(restore=True)
            if self.board.failsafe is not None:
                await self.board.rearm_failsafe(restore=False)

    async def _failsafe_arm(self, args: Mapping[str, Any]) -> None:
        """Arm with every output's safe state off (low, no pulses)."""
        outputs: dict[PinHandle | Motor, bool | float] = {
            role.handle: 0
            for role in self.pin_roles().values()
            if isinstance(role.handle, DigitalOutput | Gpio | PulseOutput | DutyPwm)
            and role.role in ("output", "servo", "soft_pwm", "duty")
        }
        await self.board.arm_failsafe(int(args["timeout_ms"]), outputs)

    async def _failsafe_disarm(self, args: Mapping[str, Any]) -> None:
        await self.board.disarm_failsafe()

    async def _failsafe_rearm(self, args: Mapping[str, Any]) -> None:
        if self.board.failsafe is None:
            raise UsageError("the failsafe is not armed: arm it first")
        await self.board.rearm_failsafe(restore=True)
