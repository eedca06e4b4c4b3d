"""Encoders as sensor_msgs/JointState, against the virtual Uno's quadrature generator.

The harness's generator (firmware/sim/quadrature.c) turns the encoder in simulated time
and reports its true position; the board's timestamps are simulated time too, so the
velocity the bridge computes from them is checked against the generator's edge rate.
The messages are read by zenoh-ros2-sdk in its own process and by a raw Zenoh subscriber
decoding with rosbags (no code of the bridge's on the receiving side).
"""

from __future__ import annotations

import math
import statistics
from typing import Any

import anyio
import pytest
import zenoh

from arduinoio_async.board import Board
from arduinoio_async.network import zenoh_config
from arduinoio_async.network._keys import undeclare
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2 import parse
from arduinoio_async.ros2._wire import topic_key
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import DEADLINE, running_bridge, sdk_peer

pytestmark = pytest.mark.sim

CPR = 400  # x4 counts per revolution
EDGES, RATE = 4_000, 8_000  # edges (x4 counts) and edges per simulated second
STREAM_MS = 10


def encoder_config() -> Any:
    return parse(
        {
            "namespace": "/robot",
            "boards": [
                {
                    "name": "uno",
                    "id": 1,
                    "frame_id": "base",
                    "stream_ms": STREAM_MS,
                    "inputs": [
                        {"pin": "D4", "pin_b": "D5", "type": "encoder", "topic": "wheel",
                         "counts_per_rev": CPR, "joint": "left_wheel", "period": 0.2},
                    ],
                }
            ],
        }
    )  # fmt: skip


async def test_an_encoder_arrives_as_joint_state_in_radians_and_rad_per_s(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    await uno.drive("D4", 0)
    await uno.drive("D5", 0)
    joint = msgs.JOINT_STATE
    key = topic_key(0, "/robot/uno/wheel", joint, msgs.type_hash(joint))
    received: list[Any] = []
    arrived = anyio.Event()
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(encoder_config(), {1: board}) as (port, _),
        sdk_peer(port) as peer,
    ):
        await peer.subscribe("/robot/uno/wheel", joint)
        listener = await anyio.to_thread.run_sync(
            zenoh.open, zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
        )
        token = anyio.lowlevel.current_token()

        def on_sample(sample: zenoh.Sample) -> None:
            received.append(msgs.decode(joint, sample.payload.to_bytes()))
            anyio.from_thread.run_sync(arrived.set, token=token)

        try:
            subscriber = listener.declare_subscriber(key, on_sample)
            with anyio.fail_after(DEADLINE):
                while not received:  # the standing encoder's periodic message
                    await arrived.wait()
                    arrived = anyio.Event()
            await uno.quadrature("D4", "D5", edges=EDGES, rate=RATE)
            truth = (await uno.wait_quadrature())[0].position
            target = truth * 2 * math.pi / CPR
            with anyio.fail_after(DEADLINE):
                while not math.isclose(received[-1].position[0], target):
                    await arrived.wait()
                    arrived = anyio.Event()
            undeclare(subscriber)
        finally:
            await anyio.to_thread.run_sync(listener.close)
        # zenoh-ros2-sdk decodes the same JointStates; its graph names the type.
        sdk = await peer.message(
            lambda m: (
                m.get("topic") == "/robot/uno/wheel" and math.isclose(m["position"][0], target)
            )
        )
        assert sdk["name"] == ["left_wheel"] and sdk["frame_id"] == "base"
        assert (await peer.topics())["/robot/uno/wheel"] == [joint]

    assert truth == EDGES
    assert received[0].position[0] == 0.0 and received[0].velocity[0] == 0.0
    assert all(list(m.name) == ["left_wheel"] and m.header.frame_id == "base" for m in received)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in received]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    # While it turned (every sample but the first and last of the run, whose window holds
    # the start or the end), the velocity is the generator's rate to within one count per
    # sample period; the board's clock and the generator share simulated time.
    moving = [m.velocity[0] for m in received if m.velocity[0] != 0.0][1:-1]
    rate = RATE * 2 * math.pi / CPR
    one_count = 2 * math.pi / CPR * 1000 / STREAM_MS
    assert len(moving) >= EDGES / RATE * 1000 / STREAM_MS / 2
    assert all(abs(v - rate) <= one_count * 1.01 for v in moving), (rate, moving)
    assert statistics.median(moving) == pytest.approx(rate, rel=0.01)
