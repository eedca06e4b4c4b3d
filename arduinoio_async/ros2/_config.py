"""The bridge's YAML configuration, checked before any board is touched.

A mistake is one :class:`ConfigError` whose text names the file, the place in it and
what is allowed (``robot.yaml: boards[0].inputs[1].pin: unknown pin 'D14' (D2-D13,
A0-A5)``), never a traceback from deep inside the bridge.  The format is documented in
``docs/ros2.md``; ``examples/ros2_two_boards.yaml`` is the paper's two-board robot.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..errors import UsageError
from ..protocol import FAILSAFE_MAX_TIMEOUT_MS, FAILSAFE_MIN_TIMEOUT_MS
from ..protocol.pins import UNO_ANALOG, UNO_DIGITAL, AnalogPin, DigitalPin, Function, capable_pins
from ..protocol.timers import TIMER_OF, Timer
from ._config_rc import rc_values
from ._config_stepper import stepper_values
from ._sources import INPUTS, OUTPUTS, PIN_NEEDS
from ._wire import fully_qualified

__all__ = ["BoardConfig", "BridgeConfig", "ConfigError", "InputConfig", "OutputConfig", "load"]

#: Input kinds -> the pins they need (from the table in :mod:`._sources`).
INPUT_KINDS = {name: kind.pins for name, kind in INPUTS.items()}
#: Output kinds -> the pins they need (likewise).
OUTPUT_KINDS = {name: kind.pins for name, kind in OUTPUTS.items()}
#: Keys only an encoder takes.
_ENCODER_KEYS = INPUTS["encoder"].keys - {"period"}


class ConfigError(UsageError):
    """The configuration file is wrong; the text says where and how."""


@dataclass(frozen=True)
class InputConfig:
    """One entry of a board's ``inputs``: what it reads and where it publishes."""

    pin: DigitalPin | AnalogPin
    kind: str
    topic: str  # fully qualified
    pull_up: bool = False
    period: float = 0.1  # analog: seconds between readings
    scale: float = 1.0  # analog: volts at the pin -> published volts (a divider)
    address: int = 0x68  # imu: the MPU-6050's I2C address
    accel_g: int = 2  # imu: accelerometer range, +-2, 4, 8 or 16 g
    gyro_dps: int = 250  # imu: gyroscope range, +-250, 500, 1000 or 2000 deg/s
    pin_b: DigitalPin | None = None  # encoder: pin B (``pin`` is A)
    #: encoder: counts per revolution of the joint in the decoding ``mode``'s units
    #: (an x4 count per edge: 4 x the encoder's lines, times any gear ratio).
    counts_per_rev: float = 0.0
    mode: str = "x4"  # encoder: x1, x2 or x4
    joint: str = ""  # encoder: the JointState's joint name
    echo: DigitalPin | None = None  # sonar: the echo pin (``pin`` is the trigger)
    rc: Mapping[str, int] = field(default_factory=dict)  # rc: :mod:`._config_rc`'s values


@dataclass(frozen=True)
class OutputConfig:
    """One entry of a board's ``outputs``: what it drives, from which topic, how safely."""

    pin: DigitalPin
    kind: str
    topic: str  # fully qualified
    #: Seconds without a fresh command before the output goes to ``safe`` (None: never).
    timeout: float | None = None
    #: The safe state: a level for ``bool``, radians for ``servo`` (None: no pulses), a
    #: speed -1..1 for ``motor``.
    safe: bool | float | None = None
    #: A motor's direction input(s) (IN1, and IN2 for drivers that can brake); a
    #: stepper's DIR pin (``pin`` is its STEP pin).
    direction: DigitalPin | None = None
    direction2: DigitalPin | None = None
    #: A stepper's top speed (steps/s) and acceleration (steps/s^2).
    max_speed: int = 1000
    acceleration: int = 1000
    #: A stepper's steps per revolution: commands are radians; None: commands are steps.
    steps_per_rev: float | None = None


@dataclass(frozen=True)
class BoardConfig:
    """One board of the file: its node name, board ID, pins and options."""

    name: str  # the node name
    board_id: int
    frame_id: str
    inputs: tuple[InputConfig, ...] = ()
    outputs: tuple[OutputConfig, ...] = ()
    diagnostics_period: float = 1.0
    #: Sample the analog inputs with the board's timer every ``stream_ms`` (stamped by the
    #: board clock) instead of reading each one every ``period`` (None).
    stream_ms: float | None = None
    #: Arm the board's link failsafe with the outputs' safe states: a dead bridge process
    #: or a pulled cable puts them safe after this many ms (None: not armed).
    link_failsafe_ms: int | None = None


@dataclass(frozen=True)
class BridgeConfig:
    """The whole file: the ROS domain, the namespace of the nodes, the boards."""

    domain_id: int = 0
    namespace: str = "/"
    boards: tuple[BoardConfig, ...] = field(default_factory=tuple)


def load(path: Path) -> BridgeConfig:
    """Read and check the configuration file ``path``."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return parse(data, str(path))


def parse(data: object, source: str = "config") -> BridgeConfig:
    """Check ``data`` (the YAML document) and build the configuration."""
    top = _mapping(data, source, {"domain_id", "namespace", "boards"})
    domain_id = top.get("domain_id", int(os.environ.get("ROS_DOMAIN_ID", "0") or 0))
    if not isinstance(domain_id, int) or isinstance(domain_id, bool) or not 0 <= domain_id <= 232:
        raise ConfigError(f"{source}: domain_id: {domain_id!r} is not a whole number 0-232")
    namespace = top.get("namespace", "/")
    if not isinstance(namespace, str) or not namespace.startswith("/"):
        raise ConfigError(f"{source}: namespace: {namespace!r} must start with '/'")
    boards_data = top.get("boards")
    if not isinstance(boards_data, list) or not boards_data:
        raise ConfigError(f"{source}: boards: a list of at least one board is needed")
    topics: dict[str, str] = {}
    names: set[str] = set()
    ids: set[int] = set()
    boards = []
    for index, item in enumerate(boards_data):
        where = f"{source}: boards[{index}]"
        board = _board(item, where, namespace, topics)
        if board.name in names:
            raise ConfigError(f"{where}.name: duplicate node name {board.name!r}")
        if board.board_id in ids:
            raise ConfigError(f"{where}.id: duplicate board ID 0x{board.board_id:04X}")
        names.add(board.name)
        ids.add(board.board_id)
        boards.append(board)
    return BridgeConfig(domain_id, namespace, tuple(boards))


def _mapping(data: object, where: str, allowed: set[str]) -> Mapping[str, Any]:
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping (key: value), got {type(data).__name__}")
    unknown = sorted(str(key) for key in data if key not in allowed)
    if unknown:
        raise ConfigError(
            f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )
    return data


def _board(data: object, where: str, namespace: str, topics: dict[str, str]) -> BoardConfig:
    allowed = {
        "name", "id", "frame_id", "inputs", "outputs", "diagnostics_period", "stream_ms",
        "link_failsafe_ms",
    }  # fmt: skip
    item = _mapping(data, where, allowed)
    name = item.get("name")
    if not isinstance(name, str) or not name.isidentifier():
        raise ConfigError(f"{where}.name: {name!r} is not a ROS node name (letters, digits, _)")
    board_id = item.get("id")
    if not isinstance(board_id, int) or isinstance(board_id, bool) or not 0 <= board_id <= 0xFFFF:
        raise ConfigError(f"{where}.id: {board_id!r} is not a board ID 0x0000-0xFFFF")
    node_ns = fully_qualified(namespace, name)
    pins: set[int] = set()
    inputs = tuple(
        _input(entry, f"{where}.inputs[{i}]", node_ns, topics, pins)
        for i, entry in enumerate(_list(item, "inputs", where))
    )
    outputs = tuple(
        _output(entry, f"{where}.outputs[{i}]", node_ns, topics, pins)
        for i, entry in enumerate(_list(item, "outputs", where))
    )
    period = _positive(item.get("diagnostics_period", 1.0), f"{where}.diagnostics_period")
    frame_id = item.get("frame_id", name)
    if not isinstance(frame_id, str):
        raise ConfigError(f"{where}.frame_id: {frame_id!r} is not a string")
    stream_ms = item.get("stream_ms")
    if stream_ms is not None and (
        isinstance(stream_ms, bool) or not isinstance(stream_ms, int | float) or stream_ms < 0.25
    ):
        raise ConfigError(f"{where}.stream_ms: {stream_ms!r} is not a period of 0.25 ms or more")
    _check_stream_timer(inputs, outputs, stream_ms is not None, where)
    link_ms = item.get("link_failsafe_ms")
    low, high = FAILSAFE_MIN_TIMEOUT_MS, FAILSAFE_MAX_TIMEOUT_MS
    if link_ms is not None and (
        isinstance(link_ms, bool) or not isinstance(link_ms, int) or not low <= link_ms <= high
    ):
        raise ConfigError(
            f"{where}.link_failsafe_ms: {link_ms!r} is not a whole number of ms, {low}-{high}"
        )
    return BoardConfig(
        name,
        board_id,
        frame_id,
        inputs,
        outputs,
        period,
        None if stream_ms is None else float(stream_ms),
        link_ms,
    )


def _check_stream_timer(
    inputs: tuple[InputConfig, ...], outputs: tuple[OutputConfig, ...], stream_ms: bool, where: str
) -> None:
    """The board's stream (encoders, or analog inputs with stream_ms) is timed by Timer0,
    which a motor's duty PWM on D5/D6 holds: the board would refuse the stream at start."""
    streams = any(s.kind == "encoder" or (stream_ms and s.kind in ("volts", "battery", "imu"))
                  for s in inputs)  # fmt: skip
    if not streams:
        return
    for index, output in enumerate(outputs):
        if output.kind == "motor" and TIMER_OF.get(output.pin) is Timer.TIMER0:
            free = [p for p in capable_pins(Function.DUTY_PWM) if isinstance(p, DigitalPin)]
            others = ", ".join(p.name for p in free if TIMER_OF.get(p) is not Timer.TIMER0)
            raise ConfigError(
                f"{where}.outputs[{index}].pin: a motor on {output.pin.name} holds Timer0, "
                f"which times the board's stream (encoders, stream_ms): use {_or(others)}"
            )


def _or(names: str) -> str:
    """'D3, D9, D10' -> 'D3, D9 or D10'."""
    head, _, last = names.rpartition(", ")
    return f"{head} or {last}" if head else last


def _list(item: Mapping[str, Any], key: str, where: str) -> list[Any]:
    value = item.get(key, [])
    if not isinstance(value, list):
        raise ConfigError(f"{where}.{key}: expected a list")
    return value


def _positive(value: object, where: str) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise ConfigError(f"{where}: {value!r} is not a positive number of seconds")
    return float(value)


#: The Uno's pin names (the bridge's configuration describes Uno boards).
_UNO_PIN_NAMES = frozenset(pin.name for pin in (*UNO_DIGITAL, *UNO_ANALOG))


def _pin(value: object, kind: str, need: str, where: str) -> DigitalPin | AnalogPin:
    if not isinstance(value, str) or value not in _UNO_PIN_NAMES:
        raise ConfigError(f"{where}.pin: unknown pin {value!r} (D2-D13, A0-A5)")
    pin: DigitalPin | AnalogPin = (
        DigitalPin[value] if value in DigitalPin.__members__ else AnalogPin[value]
    )
    ok = {
        "digital": isinstance(pin, DigitalPin),
        "analog": isinstance(pin, AnalogPin),
        "servo": pin in capable_pins(Function.SERVO_PWM),
        "counter": pin in capable_pins(Function.COUNTER),
        "duty": pin in capable_pins(Function.DUTY_PWM),
        "i2c": pin is AnalogPin.A4,
        "encoder": pin in capable_pins(Function.ENCODER),
        "sonar": pin in capable_pins(Function.SONAR),
    }[need]
    if not ok:
        raise ConfigError(f"{where}.pin: {value} cannot be a {kind!r} ({PIN_NEEDS[need]} can)")
    return pin


def _claim(pin: DigitalPin | AnalogPin, pins: set[int], where: str) -> None:
    key = int(pin) + (100 if isinstance(pin, AnalogPin) else 0)
    if key in pins:
        raise ConfigError(f"{where}.pin: {pin.name} is used twice on this board")
    pins.add(key)


def _topic(value: object, node_ns: str, topics: dict[str, str], where: str) -> str:
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{where}.topic: a topic name is needed")
    try:
        topic = fully_qualified(node_ns, value)
    except UsageError as exc:
        raise ConfigError(f"{where}.topic: {exc}") from None
    if topic in topics:
        raise ConfigError(f"{where}.topic: duplicate topic {topic} (also {topics[topic]})")
    topics[topic] = where
    return topic


def _kind(value: object, kinds: Mapping[str, str], where: str) -> str:
    if value not in kinds:
        raise ConfigError(f"{where}.type: {value!r} is not one of {', '.join(sorted(kinds))}")
    return str(value)


def _input(
    data: object, where: str, node_ns: str, topics: dict[str, str], pins: set[int]
) -> InputConfig:
    allowed = {"pin", "type", "topic"}.union(*(kind.keys for kind in INPUTS.values()))
    item = _mapping(data, where, allowed)
    kind = _kind(item.get("type"), INPUT_KINDS, where)
    if kind == "encoder":
        return _encoder(item, where, node_ns, topics, pins)
    if kind == "sonar":
        return _sonar(item, where, node_ns, topics, pins)
    if "echo" in item:
        raise ConfigError(f"{where}.echo: only a sonar takes 'echo'")
    stray = sorted(_ENCODER_KEYS & item.keys())
    if stray:
        raise ConfigError(f"{where}.{stray[0]}: only an encoder takes {stray[0]!r}")
    # An IMU sits on the I2C bridge: SDA A4 and SCL A5, both taken.
    pin = _pin(
        item.get("pin", "A4") if kind == "imu" else item.get("pin"), kind, INPUT_KINDS[kind], where
    )
    _claim(pin, pins, where)
    if kind == "imu":
        _claim(AnalogPin.A5, pins, where)
    address = item.get("address", 0x68)
    if kind != "imu" and "address" in item:
        raise ConfigError(f"{where}.address: only an imu has an I2C address")
    if address not in (0x68, 0x69):
        raise ConfigError(f"{where}.address: {address!r} is not an MPU-6050 address (0x68, 0x69)")
    pull_up = item.get("pull_up", False)
    if not isinstance(pull_up, bool):
        raise ConfigError(f"{where}.pull_up: {pull_up!r} is not true or false")
    period = _positive(item.get("period", 0.1), f"{where}.period")
    scale = item.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not math.isfinite(scale):
        raise ConfigError(f"{where}.scale: {scale!r} is not a number")
    ranges: tuple[Any, Any] = (item.get("accel_g", 2), item.get("gyro_dps", 250))
    for (key, choices), value in zip(_IMU_RANGES.items(), ranges, strict=True):
        if kind != "imu" and key in item:
            raise ConfigError(f"{where}.{key}: only an imu has {key!r}")
        if isinstance(value, bool) or value not in choices:
            raise ConfigError(f"{where}.{key}: {value!r} is not one of {_or(_names(choices))}")
    rc, problem = rc_values(item, kind)
    if problem:
        raise ConfigError(f"{where}.{problem}")
    topic = _topic(item.get("topic"), node_ns, topics, where)
    return InputConfig(pin, kind, topic, pull_up, period, float(scale), address, *ranges, rc=rc)


#: An MPU-6050's ranges: accelerometer in g, gyroscope in deg/s.
_IMU_RANGES = {"accel_g": (2, 4, 8, 16), "gyro_dps": (250, 500, 1000, 2000)}


def _names(values: tuple[int, ...]) -> str:
    return ", ".join(map(str, values))


def _output(
    data: object, where: str, node_ns: str, topics: dict[str, str], pins: set[int]
) -> OutputConfig:
    allowed = {"pin", "type", "topic", "timeout", "safe", "direction", "direction2"}
    allowed |= {"max_speed", "acceleration", "steps_per_rev"}
    item = _mapping(data, where, allowed)
    kind = _kind(item.get("type"), OUTPUT_KINDS, where)
    pin = _pin(item.get("pin"), kind, OUTPUT_KINDS[kind], where)
    _claim(pin, pins, where)
    assert isinstance(pin, DigitalPin)  # every output kind needs a digital pin
    directions: list[DigitalPin | None] = []
    for key in ("direction", "direction2"):
        if key not in item:
            directions.append(None)
            continue
        if kind != "motor" and (kind, key) != ("stepper", "direction"):
            raise ConfigError(f"{where}.{key}: only a motor or a stepper has direction pins")
        direction = _pin(item[key], kind, "digital", f"{where}.{key}")
        _claim(direction, pins, f"{where}.{key}")
        assert isinstance(direction, DigitalPin)
        directions.append(direction)
    if kind == "motor" and directions[0] is None:
        raise ConfigError(f"{where}.direction: a motor needs its direction pin (IN1)")
    if kind == "stepper" and directions[0] is None:
        raise ConfigError(f"{where}.direction: a stepper needs its driver's DIR pin")
    stepper = _stepper_options(item, kind, where)
    timeout = item.get("timeout")
    if timeout is not None:
        timeout = _positive(timeout, f"{where}.timeout")
    safe = item.get("safe")
    if kind == "bool" and not isinstance(safe, bool | None):
        raise ConfigError(f"{where}.safe: {safe!r} is not true or false")
    if (
        kind == "servo"
        and safe is not None
        and (isinstance(safe, bool) or not isinstance(safe, int | float) or abs(safe) > math.pi / 2)
    ):
        raise ConfigError(f"{where}.safe: {safe!r} is not an angle in radians, -pi/2..pi/2")
    if (
        kind == "motor"
        and safe is not None
        and (isinstance(safe, bool) or not isinstance(safe, int | float) or abs(safe) > 1)
    ):
        raise ConfigError(f"{where}.safe: {safe!r} is not a speed -1..1")
    if kind == "stepper" and safe is not None:
        raise ConfigError(f"{where}.safe: a stepper's safe state is stopped (leave safe out)")
    if timeout is not None and safe is None and kind not in ("servo", "stepper"):
        safe = False if kind == "bool" else 0.0
    topic = _topic(item.get("topic"), node_ns, topics, where)
    return OutputConfig(pin, kind, topic, timeout, safe, directions[0], directions[1], **stepper)


def _stepper_options(item: Mapping[str, Any], kind: str, where: str) -> dict[str, Any]:
    """A stepper's max_speed, acceleration and steps_per_rev (:mod:`._config_stepper`)."""
    options, problem = stepper_values(item, kind)
    if problem:
        raise ConfigError(f"{where}.{problem}")
    return options


def _encoder(
    item: Mapping[str, Any], where: str, node_ns: str, topics: dict[str, str], pins: set[int]
) -> InputConfig:
    """An encoder on pins A and B, published as a JointState from the board's stream."""
    pin = _pin(item.get("pin"), "encoder", "encoder", where)
    _claim(pin, pins, where)
    if "pin_b" not in item:
        raise ConfigError(f"{where}.pin_b: an encoder needs its pin B")
    pin_b = _pin(item["pin_b"], "encoder", "encoder", f"{where}.pin_b")
    _claim(pin_b, pins, f"{where}.pin_b")
    assert isinstance(pin, DigitalPin) and isinstance(pin_b, DigitalPin)
    cpr = item.get("counts_per_rev")
    if cpr is None:
        raise ConfigError(
            f"{where}.counts_per_rev: an encoder needs its counts per revolution "
            "(in the mode's counts: x4 counts 4 per line)"
        )
    if isinstance(cpr, bool) or not isinstance(cpr, int | float) or not math.isfinite(cpr):
        raise ConfigError(f"{where}.counts_per_rev: {cpr!r} is not a number")
    if cpr == 0:
        raise ConfigError(f"{where}.counts_per_rev: 0 is not a number of counts")
    mode = item.get("mode", "x4")
    if mode not in ("x1", "x2", "x4"):
        raise ConfigError(f"{where}.mode: {mode!r} is not one of x1, x2, x4")
    period = _positive(item.get("period", 1.0), f"{where}.period")
    topic = _topic(item.get("topic"), node_ns, topics, where)
    joint = item.get("joint", topic.rsplit("/", 1)[-1])
    if not isinstance(joint, str) or not joint:
        raise ConfigError(f"{where}.joint: {joint!r} is not a joint name")
    return InputConfig(
        pin,
        "encoder",
        topic,
        period=period,
        pin_b=pin_b,
        counts_per_rev=float(cpr),
        mode=str(mode),
        joint=joint,
    )


def _sonar(
    item: Mapping[str, Any], where: str, node_ns: str, topics: dict[str, str], pins: set[int]
) -> InputConfig:
    """An HC-SR04 (trigger ``pin``, ``echo``), published as a Range every ``period``."""
    stray = sorted(_ENCODER_KEYS & item.keys())
    if stray:
        raise ConfigError(f"{where}.{stray[0]}: only an encoder takes {stray[0]!r}")
    pin = _pin(item.get("pin"), "sonar", "sonar", where)
    _claim(pin, pins, where)
    if "echo" not in item:
        raise ConfigError(f"{where}.echo: a sonar needs its echo pin")
    echo = _pin(item["echo"], "sonar", "sonar", f"{where}.echo")
    _claim(echo, pins, f"{where}.echo")
    assert isinstance(pin, DigitalPin) and isinstance(echo, DigitalPin)
    period = _positive(item.get("period", 0.1), f"{where}.period")
    topic = _topic(item.get("topic"), node_ns, topics, where)
    return InputConfig(pin, "sonar", topic, period=period, echo=echo)
