"""A stepper driven from ROS 2: a Float64 position target in radians becomes a move the
board runs; no fresh command within the timeout stops it.  The oracle is the virtual Uno's
step log (every step pulse the fixture saw on the STEP pin), never the bridge's answer."""

from __future__ import annotations

import math

import pytest

from arduinoio_async.board import Board
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2 import parse
from arduinoio_async.ros2._config import BridgeConfig, ConfigError
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from ..e2e.steps import quiet_steps, step_log
from .conftest import running_bridge, sdk_peer

pytest.importorskip("zenoh_ros2_sdk")


def stepper_config(**extra: object) -> BridgeConfig:
    stepper = {
        "pin": "D2",
        "type": "stepper",
        "topic": "lift",
        "direction": "D3",
        "steps_per_rev": 200,
        "max_speed": 2000,
        "acceleration": 20_000,
        **extra,
    }
    return parse({"boards": [{"name": "uno", "id": 1, "outputs": [stepper]}]})


@pytest.mark.sim
async def test_a_radian_target_moves_the_stepper_exactly_and_a_timeout_stops_it(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    await step_log(uno, "D2")
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(stepper_config(timeout=0.5), {1: board}) as (port, _),
        sdk_peer(port) as peer,
    ):
        await peer.publish("/uno/lift", msgs.FLOAT64, math.pi)  # half a turn: 100 steps
        assert await quiet_steps(uno, "D2", 20_000) == 100
        # A target 50 turns away (10,000 steps, 5 s at 2,000 steps/s), then silence: the
        # command timeout stops the stepper long before it gets there.
        await peer.publish("/uno/lift", msgs.FLOAT64, 100 * math.pi + math.pi)
        stopped = await quiet_steps(uno, "D2", 20_000)
        assert 100 < stopped < 10_100


def test_a_stepper_needs_its_dir_pin_and_takes_no_safe_value() -> None:
    with pytest.raises(ConfigError, match="DIR pin"):
        parse(
            {"boards": [{"name": "u", "id": 1, "outputs": [
                {"pin": "D2", "type": "stepper", "topic": "s"}]}]}
        )  # fmt: skip
    with pytest.raises(ConfigError, match="safe state is stopped"):
        stepper_config(safe=1.0)
    with pytest.raises(ConfigError, match="max_speed"):
        stepper_config(max_speed=20_000)
    with pytest.raises(ConfigError, match="only a stepper takes steps_per_rev"):
        parse(
            {"boards": [{"name": "u", "id": 1, "outputs": [
                {"pin": "D9", "type": "servo", "topic": "s", "steps_per_rev": 200}]}]}
        )  # fmt: skip
