"""An RC receiver channel as std_msgs/Float32, against the virtual Uno's RC source model.

The harness drives D4 like a receiver (firmware/sim/rcpulse.c: a high pulse of a set
width every 20 ms) and reports the last pulse's width it drove; the oracle is that width
normalised here from the documented end points (1,000 / 1,500 / 2,000 us -> -1 / 0 / 1).
A stopped source is a lost signal: the topic then carries NaN, never a stale position.
Read by zenoh-ros2-sdk in its own process.
"""

from __future__ import annotations

import math
from typing import Any

import pytest

from arduinoio_async.board import Board
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2 import parse
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import running_bridge, sdk_peer

pytestmark = pytest.mark.sim

TOPIC = "/robot/uno/rc_steer"


def rc_config() -> Any:
    return parse(
        {"namespace": "/robot",
         "boards": [{"name": "uno", "id": 1,
                     "inputs": [{"type": "rc", "pin": "D4", "topic": "rc_steer",
                                 "period": 0.02, "timeout_ms": 60}]}]}
    )  # fmt: skip


async def test_an_rc_channel_arrives_normalised_and_a_lost_signal_as_nan(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, profile="sensing")
    await uno.rcpulse("D4", width_us=1750)
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(rc_config(), {1: board}) as (port, nodes),
        sdk_peer(port) as peer,
    ):
        await peer.subscribe(TOPIC, msgs.FLOAT32)

        def steady(m: dict[str, Any]) -> bool:
            return m.get("topic") == TOPIC and not math.isnan(m["data"]) and m["data"] > 0

        got = await peer.message(steady)
        assert (await nodes[0].status()).values["rc_signal_lost"] == ""
        (source,) = await uno.rcpulse_status()
        assert source.pulses > 0
        assert got["data"] == pytest.approx((source.last_width_us - 1500) / 500, abs=0.01)
        await uno.rcpulse_stop("D4")
        lost = await peer.message(lambda m: m.get("topic") == TOPIC and math.isnan(m["data"]))
        assert math.isnan(lost["data"])
        status = await nodes[0].status()
        assert status.values["rc_signal_lost"] == TOPIC and status.level == msgs.DIAG_WARN
        assert "RC signal lost" in status.message
