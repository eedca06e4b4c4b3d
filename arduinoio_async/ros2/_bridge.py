"""The bridge: each configured board as a ROS 2 node, its pins as topics.

Per board (:class:`BoardNode`): digital inputs publish ``std_msgs/Bool`` at start and on
every change the board reports; analog inputs publish ``std_msgs/Float32`` volts (or a
``sensor_msgs/BatteryState``) every ``period`` or, with ``stream_ms``, every sample of a
firmware-timed stream stamped with the board's clock; counters ``Int64`` and an
MPU-6050 on I2C ``sensor_msgs/Imu``.  Digital outputs take ``Bool``, servos ``Float64``
radians (0 = centre, +-pi/2 = the ends) and motors ``Float64`` speeds -1..1.  An output
with a ``timeout`` goes to its safe state when no command came for that long (the
freshness a ros2_control hardware interface promises) and stays there until the next
command; ``link_failsafe_ms`` arms the board's own watchdog with the same states.  The
diagnostics (``/diagnostics``, ``diagnostic_msgs/DiagnosticArray``) say which outputs
timed out and whether the board is there.  A board that disconnects leaves its node on
the graph; its inputs publish again once the manager has it back.

Commands are *latest wins*: a command that arrives while the previous write is still on
the wire replaces any command waiting behind it, so a fast publisher never builds a
queue of stale set-points.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, cast

import anyio
import zenoh

from ..board.imu import MPU6050
from ..errors import ArduinoIOError, UsageError
from ..protocol import I2CSpeed
from . import _messages as msgs
from ._clock import BoardClock
from ._config import BoardConfig, BridgeConfig, InputConfig, OutputConfig
from ._endpoints import Context, Node, Publisher
from ._sources import INPUTS, RangeReading, range_payload
from ._stream import StreamedInputs, streamed
from ._wire import Attachment

if TYPE_CHECKING:
    from ..board import Board
    from ..board.handles import DigitalOutput, Servo
    from ..board.motors import Motor
    from ..board.steppers import Stepper
    from ..protocol.pins import AnalogPin, CounterPin, DigitalPin, DutyPwmPin, ServoPin

__all__ = ["BoardNode", "run_bridge"]

log = logging.getLogger(__name__)

#: Seconds between looks at a board whose link failed (a Board has no event for its return).
RECONNECT_POLL = 0.25
#: Where every node publishes its diagnostics (the ROS convention, an absolute name).
DIAGNOSTICS_TOPIC = "/diagnostics"


async def run_bridge(
    session: zenoh.Session,
    config: BridgeConfig,
    boards: Mapping[int, Board],
    *,
    task_status: anyio.abc.TaskStatus[list[BoardNode]] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve every configured board (``boards``: board ID -> open Board) until cancelled.

    ``task_status.started`` gets the nodes once every node, publisher and subscription
    is declared and each input published its first value.
    """
    missing = [f"0x{b.board_id:04X}" for b in config.boards if b.board_id not in boards]
    if missing:
        raise UsageError(f"no open board for the configured ID(s) {', '.join(missing)}")
    context = Context(session, config.domain_id)
    nodes = [
        BoardNode(context, config, board_config, boards[board_config.board_id])
        for board_config in config.boards
    ]
    try:
        async with anyio.create_task_group() as tg:
            for node in nodes:
                await tg.start(node.run)
            task_status.started(nodes)
    finally:
        for node in nodes:
            node.close()


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


class BoardNode:
    """One board as the ROS 2 node ``<namespace>/<name>``."""

    def __init__(
        self, context: Context, bridge: BridgeConfig, config: BoardConfig, board: Board
    ) -> None:
        self.config = config
        self.board = board
        self.node = Node(context, bridge.namespace, config.name)
        self.clock = BoardClock()
        self.outputs: list[_Command] = []
        self.published = 0
        self.command_errors = 0
        #: Called as ``on_change(topic, sequence, stamp_ns, decoded_ns)`` after each change
        #: an input published: its attachment's sequence number, the board's time of the
        #: edge in host nanoseconds (:class:`BoardClock`) and the host time its frame was
        #: decoded (``time.time_ns()`` scale); for measurements and logging.
        self.on_change: Callable[[str, int, int, int], None] | None = None
        self._diagnostics = self.node.publisher(DIAGNOSTICS_TOPIC, msgs.DIAGNOSTIC_ARRAY)
        #: The board's firmware-timed stream, when an input comes from it.
        self.stream: StreamedInputs | None = None

    def close(self) -> None:
        """Take the node off the graph: undeclare its tokens, publishers, subscribers."""
        self.node.close()

    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Set up every configured pin, then publish and follow commands until cancelled;
        ``task_status.started()`` once each input published its first value."""
        async with anyio.create_task_group() as tg:
            for output in self.config.outputs:
                command = await self._set_up_output(output)
                self.outputs.append(command)
                tg.start_soon(self._write_commands, command)
                if output.timeout is not None:
                    tg.start_soon(self._watch_freshness, command)
            if self.config.link_failsafe_ms is not None:
                await self._arm_link_failsafe(self.config.link_failsafe_ms)
            from_stream = streamed(self.config.inputs, self.config.stream_ms)
            for source in self.config.inputs:
                if source not in from_stream:
                    await tg.start(self._publish_input, source)
            if from_stream:
                self.stream = StreamedInputs(
                    self.board,
                    from_stream,
                    period_ms=self.config.stream_ms,
                    clock=self.clock,
                    frame_id=self.config.frame_id,
                    publisher=self._publisher,
                    put=self._put,
                    link_lost=self._link_lost,
                )
                await tg.start(self.stream.run)
            tg.start_soon(self._publish_diagnostics)
            task_status.started()

    # ---- outputs -------------------------------------------------------------------------

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

    # ---- inputs --------------------------------------------------------------------------

    def _publisher(self, source: InputConfig) -> Publisher:
        return self.node.publisher(source.topic, INPUTS[source.kind].ros_type)

    def _put(self, publisher: Publisher, payload: bytes) -> None:
        publisher.publish(payload)
        self.published += 1

    async def _publish_input(
        self,
        source: InputConfig,
        *,
        task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
    ) -> None:
        publisher = self._publisher(source)
        if source.kind == "bool":
            pin = await self.board.digital_input(
                cast("DigitalPin", source.pin), pull_up=source.pull_up
            )
            started = False
            while True:  # again after the link failed and the board came back
                # Each change is published from the link's reader as its frame is decoded
                # (no hop through a queue and another task: benchmarks/ros2_latency.py);
                # those before the first reading's message wait for it, in order.
                held: list[Any] | None = []

                def on_change(change: Any) -> None:
                    if held is not None:  # noqa: B023 (this round's list: the watch is too)
                        held.append(change)  # noqa: B023
                    else:
                        self._publish_change(source.topic, publisher, change)

                try:
                    async with pin.watch(callback=on_change) as changes:
                        self._put(publisher, msgs.bool_msg(bool(await pin.read())))
                        waiting, held = held, None
                        for change in waiting or ():
                            self._publish_change(source.topic, publisher, change)
                        if not started:
                            started = True
                            task_status.started()
                        async for _ in changes:  # nothing comes: ends with the watch
                            pass
                except ArduinoIOError as exc:
                    if not started:
                        raise  # at start: the bridge does not come up, with this error
                    await self._link_lost(source.topic, exc)

        if source.kind == "imu":
            await self._publish_imu(source, publisher, task_status)
            return
        if source.kind == "sonar":
            await self._publish_sonar(source, publisher, task_status)
            return
        if source.kind == "counter":
            counter = await self.board.counter(cast("CounterPin", source.pin))
            task_status.started()
            while True:
                try:
                    self._put(publisher, msgs.int64_msg(await counter.read()))
                except ArduinoIOError as exc:
                    await self._read_failed(source.topic, exc)
                await anyio.sleep(source.period)
        analog = self.board.analog(cast("AnalogPin", source.pin))
        started = False
        while True:
            try:
                volts = await analog.read_volts() * source.scale
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                if source.kind == "volts":
                    payload = msgs.float32_msg(volts)
                else:
                    now = msgs.Stamp(time.time_ns())
                    payload = msgs.battery_state(now, self.config.frame_id, volts)
                self._put(publisher, payload)
            if not started:
                started = True
                task_status.started()
            await anyio.sleep(source.period)

    def _publish_change(self, topic: str, publisher: Publisher, change: Any) -> None:
        host_ns = time.time_ns() - int((time.monotonic() - change.host_time) * 1e9)
        board_us = self.clock.observe(change.board_time_us, host_ns)
        self._put(publisher, msgs.bool_msg(change.level))
        if self.on_change is not None:
            stamp_ns = self.clock.to_host_ns(board_us)
            self.on_change(topic, publisher.sequence, stamp_ns, host_ns)

    async def _read_failed(self, what: str, exc: ArduinoIOError) -> None:
        """A periodic read failed: once per lost link (then wait for the board), else once
        per failure."""
        if self.board.connected:
            log.warning("%s: %s: %s", self.config.name, what, exc)
        else:
            await self._link_lost(what, exc)

    async def _link_lost(self, what: str, exc: ArduinoIOError) -> None:
        """A watch or stream ended with the link (unplugged, reset): wait until the board is
        connected again (the BoardManager re-adopts it and restores its pins)."""
        log.warning("%s: %s: %s; again once the board is back", self.config.name, what, exc)
        await anyio.sleep(RECONNECT_POLL)
        while not self.board.connected:  # noqa: ASYNC110 (a Board has no event for it)
            await anyio.sleep(RECONNECT_POLL)

    async def _publish_imu(
        self, source: InputConfig, publisher: Publisher, task_status: anyio.abc.TaskStatus[None]
    ) -> None:
        """An MPU-6050 polled every ``period`` (a board without ``stream_ms``), stamped with
        the middle of each read; the helper sets the entry's ranges and scales by them."""
        imu = MPU6050(await self.board.i2c(I2CSpeed.KHZ_400), source.address)
        await imu.configure(accel_g=cast(Any, source.accel_g), gyro_dps=cast(Any, source.gyro_dps))
        task_status.started()
        while True:
            sent = time.time_ns()
            try:
                reading = await imu.read()
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                stamp = msgs.Stamp((sent + time.time_ns()) // 2)
                payload = msgs.imu(stamp, self.config.frame_id, reading.gyro, reading.accel)
                self._put(publisher, payload)
            await anyio.sleep(source.period)

    async def _publish_sonar(
        self, source: InputConfig, publisher: Publisher, task_status: anyio.abc.TaskStatus[None]
    ) -> None:
        """An HC-SR04 fired by the board, its latest reading published every ``period`` as
        a Range (no echo: +inf), stamped when it was measured; none before the first."""
        assert source.echo is not None
        sonar = await self.board.sonar(cast("DigitalPin", source.pin), source.echo)
        task_status.started()
        while True:
            try:
                reading = await sonar.read()
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                if reading.distance_mm is not None or reading.no_echo:
                    metres = None if reading.distance_mm is None else reading.distance_mm / 1000
                    stamp = msgs.Stamp(time.time_ns() - reading.age_ms * 1_000_000)
                    payload = range_payload(stamp, self.config.frame_id, RangeReading(metres))
                    self._put(publisher, payload)
            await anyio.sleep(source.period)

    # ---- diagnostics ---------------------------------------------------------------------

    async def _publish_diagnostics(self) -> None:
        while True:
            self._put(
                self._diagnostics,
                msgs.diagnostic_array(msgs.Stamp(time.time_ns()), [await self.status()]),
            )
            await anyio.sleep(self.config.diagnostics_period)

    async def status(self) -> msgs.Status:
        """The board's ``DiagnosticStatus``: ERROR when unplugged or its link failsafe
        fired, WARN while an output is in its safe state for want of commands."""
        timed_out = [c.config.topic for c in self.outputs if c.timed_out]
        values = {
            "board_id": f"0x{self.config.board_id:04X}",
            "connected": str(bool(self.board.connected)).lower(),
            "link_failsafe_tripped": str(bool(self.board.failsafe_tripped)).lower(),
            "command_timeouts": " ".join(timed_out),
            "command_errors": str(self.command_errors),
            "published": str(self.published),
            "clock_drift_ppm": f"{self.clock.drift_ppm:.1f}",
        }
        try:
            values["temperature_c"] = f"{await self.board.temperature():.1f}"
            # The link's losses since it opened: what line noise and timeouts cost.
            stats = self.board.link.stats
            for name in ("timeouts", "lost_replies", "retries", "resyncs", "garbage_bytes"):
                values[f"link_{name}"] = str(getattr(stats, name))
        except ArduinoIOError as exc:
            values.setdefault("temperature_c", f"unknown ({exc})")
        if not self.board.connected or self.board.failsafe_tripped:
            level, text = msgs.DIAG_ERROR, "board unplugged or link failsafe fired"
        elif timed_out:
            level, text = msgs.DIAG_WARN, "no fresh command: safe state on " + ", ".join(timed_out)
        else:
            level, text = msgs.DIAG_OK, "ok"
        name = f"{self.node.namespace.rstrip('/')}/{self.config.name}"
        return msgs.Status(level, name, text, values["board_id"], values)


def _degrees(radians: float) -> float:
    """Servo radians (0 = centre) -> the 0-180 degrees ``set_angle`` takes."""
    return 90.0 + math.degrees(radians)
