"""The bridge's YAML configuration: a mistake is one ConfigError that says where and why."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from arduinoio_async import A0, D2, D3, D4, D5, D7, D8, D9
from arduinoio_async.ros2 import ConfigError, load, parse

EXAMPLE = Path(__file__).parents[2] / "examples" / "ros2_two_boards.yaml"


def config(**board: Any) -> dict[str, Any]:
    return {"namespace": "/robot", "boards": [{"name": "front", "id": 1, **board}]}


def test_a_good_configuration() -> None:
    cfg = parse(
        config(
            inputs=[
                {"pin": "D3", "type": "bool", "topic": "d3", "pull_up": True},
                {"pin": "A0", "type": "volts", "topic": "/battery_volts", "period": 0.5},
            ],
            outputs=[
                {"pin": "D2", "type": "bool", "topic": "d2", "timeout": 0.2},
                {"pin": "D9", "type": "servo", "topic": "pan", "safe": 0.0},
            ],
        )
    )
    board = cfg.boards[0]
    assert (cfg.namespace, board.name, board.board_id, board.frame_id) == (
        "/robot",
        "front",
        1,
        "front",
    )
    assert [(i.pin, i.topic) for i in board.inputs] == [
        (D3, "/robot/front/d3"),
        (A0, "/battery_volts"),
    ]
    assert [(o.pin, o.topic, o.timeout, o.safe) for o in board.outputs] == [
        (D2, "/robot/front/d2", 0.2, False),  # a timeout without a safe level: low
        (D9, "/robot/front/pan", None, 0.0),
    ]


def test_the_example_configuration_loads() -> None:
    cfg = load(EXAMPLE)
    assert [b.name for b in cfg.boards] == ["front", "rear"]


@pytest.mark.parametrize(
    ("board", "message"),
    [
        ({"inputs": [{"pin": "D14", "type": "bool", "topic": "x"}]},
         r"boards\[0\]\.inputs\[0\]\.pin: unknown pin 'D14' \(D2-D13, A0-A5\)"),
        ({"inputs": [{"pin": "D3", "type": "volts", "topic": "x"}]},
         r"inputs\[0\]\.pin: D3 cannot be a 'volts' \(A0-A5 can\)"),
        ({"outputs": [{"pin": "D3", "type": "servo", "topic": "x"}]},
         r"outputs\[0\]\.pin: D3 cannot be a 'servo' \(D9, D10 can\)"),
        ({"outputs": [{"pin": "A0", "type": "bool", "topic": "x"}]},
         r"A0 cannot be a 'bool' \(D2-D13 can\)"),
        ({"inputs": [{"pin": "D3", "type": "bool", "topic": "x"}],
          "outputs": [{"pin": "D2", "type": "bool", "topic": "x"}]},
         r"outputs\[0\]\.topic: duplicate topic /robot/front/x \(also .*inputs\[0\]\)"),
        ({"inputs": [{"pin": "D3", "type": "bool", "topic": "a"},
                     {"pin": "D3", "type": "bool", "topic": "b"}]},
         r"inputs\[1\]\.pin: D3 is used twice on this board"),
        ({"inputs": [{"pin": "D3", "type": "switch", "topic": "a"}]},
         r"inputs\[0\]\.type: 'switch' is not one of battery, bool, counter, encoder, imu, "
         r"rc, sonar, volts"),
        ({"inputs": [{"pin": "D3", "type": "bool", "topic": "a", "pullup": True}]},
         r"inputs\[0\]: unknown key 'pullup'"),
        ({"outputs": [{"pin": "D2", "type": "bool", "topic": "a", "timeout": 0}]},
         r"outputs\[0\]\.timeout: 0 is not a positive number of seconds"),
        ({"outputs": [{"pin": "D9", "type": "servo", "topic": "a", "safe": 3}]},
         r"outputs\[0\]\.safe: 3 is not an angle in radians"),
        ({"id": 70000}, r"boards\[0\]\.id: 70000 is not a board ID"),
        ({"outputs": [{"pin": "D9", "type": "motor", "topic": "m"}]},
         r"outputs\[0\]\.direction: a motor needs its direction pin \(IN1\)"),
        ({"outputs": [{"pin": "D4", "type": "motor", "topic": "m", "direction": "D7"}]},
         r"outputs\[0\]\.pin: D4 cannot be a 'motor' \(D3, D5, D6, D9, D10 can\)"),
        ({"outputs": [{"pin": "D2", "type": "bool", "topic": "m", "direction": "D7"}]},
         r"outputs\[0\]\.direction: only a motor or a stepper has direction pins"),
        ({"outputs": [{"pin": "D9", "type": "motor", "topic": "m", "direction": "D9"}]},
         r"outputs\[0\]\.direction\.pin: D9 is used twice"),
        ({"inputs": [{"pin": "D4", "type": "counter", "topic": "c"}]},
         r"inputs\[0\]\.pin: D4 cannot be a 'counter' \(D2, D3 can\)"),
        ({"link_failsafe_ms": 5},
         r"boards\[0\]\.link_failsafe_ms: 5 is not a whole number of ms, 20-10000"),
        ({"inputs": [{"type": "imu", "topic": "imu", "address": 0x50}]},
         r"inputs\[0\]\.address: 80 is not an MPU-6050 address \(0x68, 0x69\)"),
        ({"inputs": [{"type": "imu", "topic": "imu", "accel_g": 3}]},
         r"inputs\[0\]\.accel_g: 3 is not one of 2, 4, 8 or 16"),
        ({"inputs": [{"type": "imu", "topic": "imu", "gyro_dps": True}]},
         r"inputs\[0\]\.gyro_dps: True is not one of 250, 500, 1000 or 2000"),
        ({"inputs": [{"pin": "A0", "type": "volts", "topic": "v", "accel_g": 4}]},
         r"inputs\[0\]\.accel_g: only an imu has 'accel_g'"),
        ({"inputs": [{"type": "imu", "topic": "imu"},
                     {"pin": "A5", "type": "volts", "topic": "v"}]},
         r"inputs\[1\]\.pin: A5 is used twice on this board"),
        ({"stream_ms": 0.1}, r"boards\[0\]\.stream_ms: 0.1 is not a period of 0.25 ms or more"),
        # Encoders (JointState): pins A and B, counts per revolution, their own keys.
        ({"inputs": [{"pin": "D14", "pin_b": "D3", "type": "encoder", "topic": "e",
                      "counts_per_rev": 2048}]},
         r"inputs\[0\]\.pin: unknown pin 'D14' \(D2-D13, A0-A5\)"),
        ({"inputs": [{"pin": "D2", "pin_b": "A0", "type": "encoder", "topic": "e",
                      "counts_per_rev": 2048}]},
         r"inputs\[0\]\.pin_b\.pin: A0 cannot be a 'encoder' \(D2-D13 can\)"),
        ({"inputs": [{"pin": "D2", "type": "encoder", "topic": "e", "counts_per_rev": 2048}]},
         r"inputs\[0\]\.pin_b: an encoder needs its pin B"),
        ({"inputs": [{"pin": "D2", "pin_b": "D3", "type": "encoder", "topic": "e"}]},
         r"inputs\[0\]\.counts_per_rev: an encoder needs its counts per revolution"),
        ({"inputs": [{"pin": "D2", "pin_b": "D3", "type": "encoder", "topic": "e",
                      "counts_per_rev": 0}]},
         r"inputs\[0\]\.counts_per_rev: 0 is not a number of counts"),
        ({"inputs": [{"pin": "D2", "pin_b": "D2", "type": "encoder", "topic": "e",
                      "counts_per_rev": 8}]},
         r"inputs\[0\]\.pin_b\.pin: D2 is used twice on this board"),
        ({"inputs": [{"pin": "D2", "pin_b": "D3", "type": "encoder", "topic": "e",
                      "counts_per_rev": 8},
                     {"pin": "D4", "pin_b": "D5", "type": "encoder", "topic": "e",
                      "counts_per_rev": 8}]},
         r"inputs\[1\]\.topic: duplicate topic /robot/front/e"),
        ({"inputs": [{"pin": "D2", "pin_b": "D3", "type": "encoder", "topic": "e",
                      "counts_per_rev": 8, "mode": "x3"}]},
         r"inputs\[0\]\.mode: 'x3' is not one of x1, x2, x4"),
        ({"inputs": [{"pin": "D2", "type": "bool", "topic": "b", "counts_per_rev": 8}]},
         r"inputs\[0\]\.counts_per_rev: only an encoder takes 'counts_per_rev'"),
        # Sonars (Range): a trigger pin and an echo pin.
        ({"inputs": [{"pin": "D7", "type": "sonar", "topic": "s"}]},
         r"inputs\[0\]\.echo: a sonar needs its echo pin"),
        ({"inputs": [{"pin": "D7", "echo": "D7", "type": "sonar", "topic": "s"}]},
         r"inputs\[0\]\.echo\.pin: D7 is used twice on this board"),
        ({"inputs": [{"pin": "D7", "echo": "A1", "type": "sonar", "topic": "s"}]},
         r"inputs\[0\]\.echo\.pin: A1 cannot be a 'sonar' \(D2-D13 can\)"),
        ({"inputs": [{"pin": "D2", "type": "bool", "topic": "b", "echo": "D3"}]},
         r"inputs\[0\]\.echo: only a sonar takes 'echo'"),
        ({"inputs": [{"pin": "D2", "echo": "D3", "type": "sonar", "topic": "s",
                      "counts_per_rev": 8}]},
         r"inputs\[0\]\.counts_per_rev: only an encoder takes 'counts_per_rev'"),
        # The stream's samples are timed by Timer0, which a motor's duty PWM on D5/D6 holds.
        ({"inputs": [{"pin": "D2", "pin_b": "D3", "type": "encoder", "topic": "e",
                      "counts_per_rev": 8}],
          "outputs": [{"pin": "D5", "type": "motor", "topic": "m", "direction": "D4"}]},
         r"boards\[0\]\.outputs\[0\]\.pin: a motor on D5 holds Timer0, which times the "
         r"board's stream \(encoders, stream_ms\): use D3, D9 or D10"),
        ({"stream_ms": 5, "inputs": [{"pin": "A0", "type": "volts", "topic": "v"}],
          "outputs": [{"pin": "D6", "type": "motor", "topic": "m", "direction": "D4"}]},
         r"outputs\[0\]\.pin: a motor on D6 holds Timer0"),
    ],
)  # fmt: skip
def test_mistakes_are_named_with_their_place(board: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse(config(**board), "robot.yaml")


def test_an_encoder_entry() -> None:
    entry = {"pin": "D4", "pin_b": "D5", "type": "encoder", "topic": "wheel", "counts_per_rev": 800}
    source = parse(config(inputs=[entry])).boards[0].inputs[0]
    assert (source.pin, source.pin_b, source.kind) == (D4, D5, "encoder")
    assert (source.counts_per_rev, source.mode, source.joint) == (800.0, "x4", "wheel")
    assert source.topic == "/robot/front/wheel" and source.period == 1.0


def test_a_sonar_entry() -> None:
    entry = {"pin": "D7", "echo": "D8", "type": "sonar", "topic": "range_front", "period": 0.05}
    source = parse(config(inputs=[entry])).boards[0].inputs[0]
    assert (source.pin, source.echo, source.kind) == (D7, D8, "sonar")
    assert source.topic == "/robot/front/range_front" and source.period == 0.05


def test_duplicate_nodes_and_board_ids() -> None:
    two = {"boards": [{"name": "a", "id": 1}, {"name": "a", "id": 2}]}
    with pytest.raises(ConfigError, match=r"boards\[1\]\.name: duplicate node name 'a'"):
        parse(two)
    two = {"boards": [{"name": "a", "id": 1}, {"name": "b", "id": 1}]}
    with pytest.raises(ConfigError, match=r"boards\[1\]\.id: duplicate board ID 0x0001"):
        parse(two)


def test_a_file_that_is_not_yaml_or_not_there(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("boards: [\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load(bad)
    bad.write_text("- 1\n")
    with pytest.raises(ConfigError, match="expected a mapping"):
        load(bad)


def test_an_rc_entry_with_its_defaults_and_its_own_end_points() -> None:
    entry = {"pin": "D4", "type": "rc", "topic": "rc_steer"}
    source = parse(config(inputs=[entry])).boards[0].inputs[0]
    assert (source.pin, source.kind, source.topic) == (D4, "rc", "/robot/front/rc_steer")
    defaults = {"timeout_ms": 100, "low_us": 1000, "centre_us": 1500, "high_us": 2000}
    assert dict(source.rc) == defaults
    throttle = {**entry, "low_us": 1100, "centre_us": 1100, "high_us": 1900, "timeout_ms": 60}
    source = parse(config(inputs=[throttle])).boards[0].inputs[0]
    assert dict(source.rc) == {"timeout_ms": 60, "low_us": 1100, "centre_us": 1100, "high_us": 1900}


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"pin": "A0", "type": "rc"}, r"inputs\[0\]\.pin: A0 cannot be a 'rc' \(D2-D13 can\)"),
        ({"pin": "D4", "type": "rc", "timeout_ms": 0},
         r"inputs\[0\]\.timeout_ms: 0 is not 1-65535"),
        ({"pin": "D4", "type": "rc", "timeout_ms": 1.5},
         r"inputs\[0\]\.timeout_ms: 1\.5 is not a whole number of ms"),
        ({"pin": "D4", "type": "rc", "low_us": 2000, "high_us": 1000},
         r"inputs\[0\]\.low_us/centre_us/high_us: need low <= centre < high, got 2000/1500/1000"),
        ({"pin": "D4", "type": "bool", "low_us": 900},
         r"inputs\[0\]\.low_us: only an rc input takes 'low_us'"),
    ],
)  # fmt: skip
def test_rc_entry_mistakes(entry: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse(config(inputs=[{**entry, "topic": "x"}]))
