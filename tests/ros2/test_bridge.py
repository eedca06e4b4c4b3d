"""The bridge against peers nobody here wrote: zenoh-ros2-sdk in a separate process, and a
raw Zenoh subscriber decoding with rosbags.

The virtual Uno's loopback fixture jumpers D2 to D3, so a ROS message on the D2 topic
that reaches the pin comes back as a Bool on the D3 topic; the fixture's view of D2 is the
oracle that the level really changed (and, after a command timeout, really went safe).
"""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path
from typing import Any

import anyio
import pytest
import zenoh

from arduinoio_async import FakeBoard
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import UsageError
from arduinoio_async.network import zenoh_config
from arduinoio_async.network._keys import undeclare
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2 import load, parse, run_bridge
from arduinoio_async.ros2._wire import decode_attachment, graph_key, topic_key
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import DEADLINE, running_bridge, sdk_peer

pytest.importorskip("zenoh_ros2_sdk")

BOOL = "std_msgs/msg/Bool"


def loopback_config(timeout: float | None = None) -> Any:
    d2: dict[str, Any] = {"pin": "D2", "type": "bool", "topic": "d2"}
    if timeout is not None:
        d2["timeout"] = timeout
    return parse(
        {
            "namespace": "/robot",
            "boards": [
                {
                    "name": "uno",
                    "id": 1,
                    "inputs": [{"pin": "D3", "type": "bool", "topic": "d3"}],
                    "outputs": [d2],
                }
            ],
        }
    )


def is_d3(level: bool) -> Any:
    return lambda item: item.get("topic") == "/robot/uno/d3" and item["data"] is level


@pytest.mark.sim
async def test_d2_from_a_ros_message_reaches_d3_and_comes_back_as_a_bool(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(loopback_config(), {1: board}) as (port, _),
        sdk_peer(port) as peer,
    ):
        await peer.subscribe("/robot/uno/d3", BOOL)
        for level in (True, False, True):
            await peer.publish("/robot/uno/d2", BOOL, level)
            await peer.message(is_d3(level))
            assert (await uno.pin(2)).level == level  # the fixture saw the pin move

        # The graph as the peer reads it from the liveliness tokens.
        topics = await peer.topics()
        assert topics["/robot/uno/d2"] == [BOOL]
        assert topics["/robot/uno/d3"] == [BOOL]
        assert topics["/diagnostics"] == ["diagnostic_msgs/msg/DiagnosticArray"]
        d3 = await peer.info("/robot/uno/d3")
        assert ["/robot", "uno"] in d3["publishers"]
        d2 = await peer.info("/robot/uno/d2")
        assert ["/robot", "uno"] in d2["subscribers"]


@pytest.mark.sim
async def test_a_command_timeout_puts_the_output_in_its_safe_state(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(loopback_config(timeout=0.3), {1: board}) as (port, nodes),
        sdk_peer(port) as peer,
    ):
        await peer.subscribe("/robot/uno/d3", BOOL)
        sent = time.time_ns()  # before the publish: the command cannot arrive earlier
        await peer.publish("/robot/uno/d2", BOOL, True)
        high = await peer.message(is_d3(True))
        assert (await uno.pin(2)).level == 1
        # No further command: the output falls to its safe level (low) by itself.
        low = await peer.message(is_d3(False))
        assert (await uno.pin(2)).level == 0
        assert low["received_ns"] - sent >= 300_000_000  # not before the timeout
        assert low["received_ns"] > high["received_ns"]
        status = await nodes[0].status()
        assert status.level == msgs.DIAG_WARN
        assert status.values["command_timeouts"] == "/robot/uno/d2"
        # A fresh command ends the safe state.
        await peer.publish("/robot/uno/d2", BOOL, True)
        await peer.message(is_d3(True))
        assert (await nodes[0].status()).level == msgs.DIAG_OK


async def test_a_raw_zenoh_subscriber_sees_cdr_and_consecutive_sequence_numbers() -> None:
    config = parse(
        {
            "boards": [
                {
                    "name": "fake",
                    "id": 1,
                    "inputs": [
                        {"pin": "D3", "type": "bool", "topic": "d3"},
                        {"pin": "A0", "type": "volts", "topic": "a0", "period": 0.01},
                    ],
                }
            ]
        }
    )
    received: list[tuple[str, bytes, bytes]] = []
    got, volts_seen = anyio.Event(), anyio.Event()

    async with FakeBoard(board_id=1) as fake, Board.connect(fake.host_stream) as board:
        fake.analog[0] = 512
        async with running_bridge(config, {1: board}) as (port, _):
            config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
            listener = await anyio.to_thread.run_sync(zenoh.open, config_)
            try:
                d3_key = topic_key(0, "/fake/d3", BOOL, msgs.type_hash(BOOL))
                a0_key = topic_key(0, "/fake/a0", msgs.FLOAT32, msgs.type_hash(msgs.FLOAT32))
                token = anyio.lowlevel.current_token()

                def on_sample(sample: zenoh.Sample) -> None:
                    assert sample.attachment is not None
                    item = (str(sample.key_expr), sample.payload.to_bytes(),
                            sample.attachment.to_bytes())  # fmt: skip
                    received.append(item)
                    if item[0] == a0_key:
                        anyio.from_thread.run_sync(volts_seen.set, token=token)
                    if sum(key == d3_key for key, _, _ in received) >= 4:
                        anyio.from_thread.run_sync(got.set, token=token)

                subscriber = listener.declare_subscriber(d3_key, on_sample)
                a0 = listener.declare_subscriber(a0_key, on_sample)
                with anyio.fail_after(DEADLINE):
                    await volts_seen.wait()  # the subscribers are known to the bridge
                    for level in (True, False, True, False):
                        fake.drive(3, level)
                    await got.wait()
                undeclare(subscriber)
                undeclare(a0)
            finally:
                await anyio.to_thread.run_sync(listener.close)

    d3 = [(msgs.decode(BOOL, payload).data, decode_attachment(att))
          for key, payload, att in received if key == d3_key]  # fmt: skip
    assert [level for level, _ in d3][-4:] == [True, False, True, False]
    sequences = [att.sequence for _, att in d3]
    assert sequences == list(range(sequences[0], sequences[0] + len(sequences)))
    assert len({att.gid for _, att in d3}) == 1
    stamps = [att.timestamp_ns for _, att in d3]
    assert stamps == sorted(stamps)
    volts = [msgs.decode(msgs.FLOAT32, payload).data
             for key, payload, _ in received if key == a0_key]  # fmt: skip
    assert volts[0] == pytest.approx(512 * 5.0 / 1024, abs=0.01)


async def test_streamed_analog_inputs_carry_the_boards_sampling_time_as_header_stamp() -> None:
    """``stream_ms``: one firmware-timed stream feeds the analog inputs; each BatteryState's
    stamp is the sampling instant on the board's clock, converted to host time."""
    config = parse(
        {
            "boards": [
                {
                    "name": "fake",
                    "id": 1,
                    "stream_ms": 5,
                    "inputs": [{"pin": "A1", "type": "battery", "topic": "battery", "scale": 3}],
                }
            ]
        }
    )
    battery = msgs.BATTERY_STATE
    key = topic_key(0, "/fake/battery", battery, msgs.type_hash(battery))
    received: list[tuple[bytes, int]] = []
    enough = anyio.Event()
    async with FakeBoard(board_id=1) as fake, Board.connect(fake.host_stream) as board:
        fake.analog[1] = 256
        async with running_bridge(config, {1: board}) as (port, _):
            config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
            listener = await anyio.to_thread.run_sync(zenoh.open, config_)
            token = anyio.lowlevel.current_token()

            def on_sample(sample: zenoh.Sample) -> None:
                received.append((sample.payload.to_bytes(), time.time_ns()))
                if len(received) == 100:
                    anyio.from_thread.run_sync(enough.set, token=token)

            try:
                subscriber = listener.declare_subscriber(key, on_sample)
                with anyio.fail_after(DEADLINE):
                    await enough.wait()
                undeclare(subscriber)
            finally:
                await anyio.to_thread.run_sync(listener.close)
    messages = [(msgs.decode(battery, payload), at) for payload, at in received[:100]]
    assert {round(m.voltage, 3) for m, _ in messages} == {round(256 * 5 / 1024 * 3, 3)}
    stamps = [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m, _ in messages]
    steps = [b - a for a, b in itertools.pairwise(stamps)]
    # The fake board's clock is the event loop's: each stamp is its sampling instant (every
    # 5 ms, later when the loaded loop sleeps longer), never in the future of the receipt.
    assert all(step > 0 for step in steps)
    assert sum(steps) / len(steps) >= 4_500_000
    assert all(
        0 <= at - stamp < 1_000_000_000 for stamp, (_, at) in zip(stamps, messages, strict=True)
    )


async def wait_until(condition: Any) -> None:
    """Poll the fake board's state (it has no event for it) until ``condition()`` holds."""
    with anyio.fail_after(DEADLINE):
        while not condition():  # noqa: ASYNC110 (the fake board has no event for it)
            await anyio.sleep(0.005)


async def test_a_motor_follows_float64_commands_and_stops_when_they_stop() -> None:
    config = parse(
        {
            "boards": [
                {
                    "name": "fake",
                    "id": 1,
                    "inputs": [{"pin": "D2", "type": "counter", "topic": "count", "period": 0.02}],
                    "outputs": [
                        {"pin": "D9", "type": "motor", "topic": "wheel", "direction": "D7",
                         "timeout": 0.3},
                    ],
                }
            ]
        }
    )  # fmt: skip

    def duty() -> float:
        return fake.duties.get(9, (0, 0))[1] / p.DUTY_FULL

    async with (
        FakeBoard(board_id=1) as fake,
        Board.connect(fake.host_stream) as board,
        running_bridge(config, {1: board}) as (port, _),
        sdk_peer(port) as peer,
    ):
        await peer.publish("/fake/wheel", msgs.FLOAT64, -0.5)
        await wait_until(lambda: abs(duty() - 0.5) < 0.01)
        assert fake.levels[7] is False  # IN1 low: reverse
        # No further command: the motor stops by itself after the timeout.
        await wait_until(lambda: duty() == 0)
        # Counter: edges on D2 reach the Int64 topic.
        await peer.subscribe("/fake/count", msgs.INT64)
        for _ in range(3):
            fake.drive(2, True)
            fake.drive(2, False)
        await peer.message(lambda m: m.get("topic") == "/fake/count" and m["data"] == 3)


async def test_the_link_failsafe_is_armed_with_the_outputs_safe_states() -> None:
    """``link_failsafe_ms``: a host that falls silent leaves the outputs as the command
    timeout would; the diagnostics say the link failsafe fired."""
    config = parse(
        {
            "boards": [
                {
                    "name": "fake",
                    "id": 1,
                    "link_failsafe_ms": 200,
                    "outputs": [
                        {"pin": "D2", "type": "bool", "topic": "d2", "timeout": 5, "safe": True},
                        {"pin": "D9", "type": "servo", "topic": "pan", "safe": 0.0},
                    ],
                }
            ]
        }
    )
    async with (
        FakeBoard(board_id=1) as fake,
        Board.connect(fake.host_stream) as board,
        running_bridge(config, {1: board}) as (_, nodes),
    ):
        armed = board.failsafe
        assert armed is not None and armed.timeout_ms == 200
        fake.pulses[9] = 1234
        await fake.expire_failsafe()  # as if the host had been silent for 200 ms
        assert fake.levels[2] is True
        assert fake.pulses[9] == 1500  # the centre of 1,000-2,000 us: 0 rad
        await wait_until(lambda: board.failsafe_tripped)
        status = await nodes[0].status()
        assert status.level == msgs.DIAG_ERROR
        assert status.values["link_failsafe_tripped"] == "true"


async def test_the_node_token_and_the_diagnostics_as_a_raw_zenoh_peer_sees_them() -> None:
    config = parse({"namespace": "/robot", "boards": [{"name": "fake", "id": 7}]})
    diagnostics = msgs.DIAGNOSTIC_ARRAY
    key = topic_key(0, "/diagnostics", diagnostics, msgs.type_hash(diagnostics))
    arrived: list[bytes] = []
    got = anyio.Event()
    async with (
        FakeBoard(board_id=7) as fake,
        Board.connect(fake.host_stream) as board,
        running_bridge(config, {7: board}) as (port, _),
    ):
        config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
        listener = await anyio.to_thread.run_sync(zenoh.open, config_)
        token = anyio.lowlevel.current_token()

        def on_sample(sample: zenoh.Sample) -> None:
            arrived.append(sample.payload.to_bytes())
            anyio.from_thread.run_sync(got.set, token=token)

        def graph() -> list[str]:
            replies = listener.liveliness().get(graph_key(0), timeout=5)
            return [str(reply.ok.key_expr) for reply in replies if reply.ok is not None]

        try:
            subscriber = listener.declare_subscriber(key, on_sample)
            with anyio.fail_after(DEADLINE):
                await got.wait()
            undeclare(subscriber)
            tokens = await anyio.to_thread.run_sync(graph)
        finally:
            await anyio.to_thread.run_sync(listener.close)
    nodes = [t.split("/") for t in tokens if t.split("/")[5] == "NN"]
    assert [(n[3] == n[4], n[6:]) for n in nodes] == [(True, ["%", "%robot", "fake"])]
    publishers = [t for t in tokens if t.split("/")[5] == "MP"]
    assert any(
        "/%diagnostics/diagnostic_msgs::msg::dds_::DiagnosticArray_/" in t for t in publishers
    )
    status = msgs.decode(diagnostics, arrived[0]).status[0]
    assert (status.level, status.name, status.hardware_id) == (
        msgs.DIAG_OK,
        "/robot/fake",
        "0x0007",
    )
    values = {kv.key: kv.value for kv in status.values}
    assert values["connected"] == "true"
    assert values["temperature_c"] == f"{board_temperature(fake):.1f}"
    assert values["link_timeouts"] == values["link_lost_replies"] == "0"  # a clean link


def board_temperature(fake: FakeBoard) -> float:
    """The temperature the fake board reports, as the protocol converts it."""
    return float(p.ReadTemperatureReply(fake.temperature_raw).celsius)


async def test_an_mpu6050_on_i2c_arrives_as_imu_in_si_units() -> None:
    """The fake board's I2C device at 0x68 holds an MPU-6050's registers: 1 g on x and
    1 deg/s about z at the power-on ranges; the bridge wakes it and publishes Imu."""
    config = parse(
        {"boards": [{"name": "fake", "id": 1,
                     "inputs": [{"type": "imu", "topic": "imu", "period": 0.005}]}]}
    )  # fmt: skip
    imu = msgs.IMU
    key = topic_key(0, "/fake/imu", imu, msgs.type_hash(imu))
    received: list[tuple[bytes, bytes]] = []
    enough = anyio.Event()
    async with FakeBoard(board_id=1) as fake, Board.connect(fake.host_stream) as board:
        registers = bytearray(256)
        registers[0x75], registers[0x6B] = 0x68, 0x40  # WHO_AM_I; asleep after power-on
        registers[0x3B:0x3D] = (16384).to_bytes(2, "big")  # ACCEL_XOUT: 1 g
        registers[0x47:0x49] = (-131).to_bytes(2, "big", signed=True)  # GYRO_ZOUT: -1 deg/s
        fake.i2c_devices[0x68] = registers
        async with running_bridge(config, {1: board}) as (port, _):
            config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
            listener = await anyio.to_thread.run_sync(zenoh.open, config_)
            token = anyio.lowlevel.current_token()

            def on_sample(sample: zenoh.Sample) -> None:
                assert sample.attachment is not None
                received.append((sample.payload.to_bytes(), sample.attachment.to_bytes()))
                if len(received) == 20:
                    anyio.from_thread.run_sync(enough.set, token=token)

            try:
                subscriber = listener.declare_subscriber(key, on_sample)
                with anyio.fail_after(DEADLINE):
                    await enough.wait()
                undeclare(subscriber)
            finally:
                await anyio.to_thread.run_sync(listener.close)
    assert registers[0x6B] == 1  # woken up (clock: the gyro PLL)
    messages = [msgs.decode(imu, payload) for payload, _ in received[:20]]
    assert [m.linear_acceleration.x for m in messages] == pytest.approx([9.80665] * 20)
    assert [m.angular_velocity.z for m in messages] == pytest.approx([-math.pi / 180] * 20)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in messages]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    sequences = [decode_attachment(att).sequence for _, att in received[:20]]
    assert sequences == list(range(sequences[0], sequences[0] + 20))


async def test_a_sonar_arrives_as_range_in_metres_and_no_echo_as_inf() -> None:
    """The fake board's sonar model: an object 1.234 m ahead, then nothing in range."""
    config = parse(
        {"boards": [{"name": "fake", "id": 1,
                     "inputs": [{"pin": "D7", "echo": "D8", "type": "sonar",
                                 "topic": "range", "period": 0.005}]}]}
    )  # fmt: skip
    key = topic_key(0, "/fake/range", msgs.RANGE, msgs.type_hash(msgs.RANGE))
    received: list[bytes] = []
    enough = anyio.Event()
    async with FakeBoard(board_id=1) as fake, Board.connect(fake.host_stream) as board:
        fake.set_sonar(7, 1234)
        async with running_bridge(config, {1: board}) as (port, _):
            config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
            listener = await anyio.to_thread.run_sync(zenoh.open, config_)
            token = anyio.lowlevel.current_token()

            def on_sample(sample: zenoh.Sample) -> None:
                received.append(sample.payload.to_bytes())
                ranges = [msgs.decode(msgs.RANGE, r).range for r in received]
                if any(math.isinf(r) for r in ranges):
                    anyio.from_thread.run_sync(enough.set, token=token)
                elif len(received) == 5:
                    fake.set_sonar(7, None)

            try:
                subscriber = listener.declare_subscriber(key, on_sample)
                with anyio.fail_after(DEADLINE):
                    await enough.wait()
                undeclare(subscriber)
            finally:
                await anyio.to_thread.run_sync(listener.close)
    messages = [msgs.decode(msgs.RANGE, payload) for payload in received]
    assert messages[0].range == pytest.approx(1.234)
    assert messages[0].radiation_type == 0 and messages[0].max_range == pytest.approx(4.0)
    assert math.isinf(messages[-1].range)
    assert fake.role(7) == "sonar" and fake.role(8) == "sonar"


async def test_the_example_robot_comes_up_on_two_fake_boards() -> None:
    """examples/ros2_two_boards.yaml sets up every pin it names on boards 1 and 2."""
    config = load(Path(__file__).parents[2] / "examples" / "ros2_two_boards.yaml")
    async with (
        FakeBoard(board_id=1) as front,
        FakeBoard(board_id=2) as rear,
        Board.connect(front.host_stream) as front_board,
        Board.connect(rear.host_stream) as rear_board,
    ):
        front.i2c_devices[0x68] = bytearray(256)
        front.i2c_devices[0x68][0x75] = 0x68
        async with running_bridge(config, {1: front_board, 2: rear_board}) as (_, nodes):
            assert [n.config.name for n in nodes] == ["front", "rear"]
            assert front_board.failsafe is not None and rear_board.failsafe is not None
            assert front.role(13) == "output" and rear.role(4) == "output"
            assert front.role(7) == front.role(8) == "sonar"


async def test_an_unplugged_board_leaves_the_bridge_up_and_says_so() -> None:
    """The watch and the periodic reads end with the link; the node stays on the graph,
    its diagnostics turn ERROR, and the bridge ends cleanly when asked."""
    config = parse(
        {
            "boards": [
                {
                    "name": "fake",
                    "id": 1,
                    "diagnostics_period": 0.05,
                    "stream_ms": 10,
                    "inputs": [
                        {"pin": "D3", "type": "bool", "topic": "d3"},
                        {"pin": "A0", "type": "volts", "topic": "a0"},
                        {"pin": "D2", "type": "counter", "topic": "n", "period": 0.02},
                    ],
                }
            ]
        }
    )
    diagnostics = msgs.DIAGNOSTIC_ARRAY
    key = topic_key(0, "/diagnostics", diagnostics, msgs.type_hash(diagnostics))
    unplugged = anyio.Event()
    async with (
        FakeBoard(board_id=1) as fake,
        Board.connect(fake.host_stream) as board,
        running_bridge(config, {1: board}) as (port, _),
    ):
        config_ = zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
        listener = await anyio.to_thread.run_sync(zenoh.open, config_)
        token = anyio.lowlevel.current_token()

        def on_sample(sample: zenoh.Sample) -> None:
            status = msgs.decode(diagnostics, sample.payload.to_bytes()).status[0]
            values = {kv.key: kv.value for kv in status.values}
            if status.level == msgs.DIAG_ERROR and values["connected"] == "false":
                anyio.from_thread.run_sync(unplugged.set, token=token)

        try:
            subscriber = listener.declare_subscriber(key, on_sample)
            await fake.unplug()
            with anyio.fail_after(DEADLINE):
                await unplugged.wait()
            undeclare(subscriber)
        finally:
            await anyio.to_thread.run_sync(listener.close)


async def test_a_configured_board_that_is_not_given_is_named() -> None:
    config = parse({"boards": [{"name": "a", "id": 1}, {"name": "b", "id": 0x0A}]})
    async with FakeBoard(board_id=1) as fake, Board.connect(fake.host_stream) as board:
        session = await anyio.to_thread.run_sync(zenoh.open, zenoh_config())
        try:
            with pytest.raises(
                UsageError, match=r"no open board for the configured ID\(s\) 0x000A"
            ):
                await run_bridge(session, config, {1: board})
        finally:
            await anyio.to_thread.run_sync(session.close)
