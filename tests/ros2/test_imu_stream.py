"""The streamed IMU as sensor_msgs/Imu, against the virtual Uno's MPU-6050 model.

The board reads the MPU-6050's 14 data bytes every stream period (an I2C register block
in the stream); the harness's model (firmware/sim/mpu6050.c) logs every read it served,
with the simulated time of the read.  The oracle is that log: each message's values are
the bytes the model served for it, scaled here from the datasheet (not by the library's
helper), and its stamp advances by the simulated time between the reads.  The messages
are read by zenoh-ros2-sdk in its own process; a raw Zenoh subscriber reads the
attachments' sequence numbers.
"""

from __future__ import annotations

import itertools
import math
import statistics
import struct
from typing import Any

import anyio
import pytest
import zenoh

from arduinoio_async.board import Board
from arduinoio_async.network import zenoh_config
from arduinoio_async.network._keys import undeclare
from arduinoio_async.ros2 import _messages as msgs
from arduinoio_async.ros2 import parse
from arduinoio_async.ros2._wire import decode_attachment, topic_key
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import running_bridge, sdk_peer

pytestmark = pytest.mark.sim

STREAM_MS = 5  # 200 Hz
COUNT = 200  # one second of board time
ACCEL_G, GYRO_DPS = 4, 500
#: The clock estimate's documented spread on the simulator (docs/ros2.md, "Error") and
#: the documented board edge -> ROS subscriber p99 (docs/ros2.md, "Latency").
STAMP_ERROR_NS = 3_200_000
LATENCY_P99_NS = 6_700_000


def imu_config() -> Any:
    return parse(
        {"namespace": "/robot",
         "boards": [{"name": "uno", "id": 1, "frame_id": "imu_link", "stream_ms": STREAM_MS,
                     "inputs": [{"type": "imu", "topic": "imu", "accel_g": ACCEL_G,
                                 "gyro_dps": GYRO_DPS}]}]}
    )  # fmt: skip


def datasheet(data: bytes) -> tuple[list[float], list[float]]:
    """The 14 bytes in m/s^2 and rad/s at ACCEL_G and GYRO_DPS (MPU-6050 datasheet:
    16384/ACCEL_G LSB per g; 131, 65.5, 32.8, 16.4 LSB per deg/s)."""
    ax, ay, az, _t, gx, gy, gz = struct.unpack(">7h", data)
    g = 9.80665 * ACCEL_G / 32768
    rad = math.pi / 180 / {250: 131.0, 500: 65.5, 1000: 32.8, 2000: 16.4}[GYRO_DPS]
    return [ax * g, ay * g, az * g], [gx * rad, gy * rad, gz * rad]


async def served(uno: VirtualUno) -> list[tuple[float, bytes]]:
    """Every read the model logged: (simulated us, 14 bytes)."""
    out: list[tuple[float, bytes]] = []
    while True:
        reply: dict[str, Any] = await uno.command("imu_reads", **{"from": len(out)})
        assert reply["from"] == len(out), "the model's log ring overran"
        out += [(float(us), bytes(data)) for us, data in reply["reads"]]
        if len(out) >= reply["logged"]:
            return out


async def test_a_streamed_imu_arrives_at_200_hz_with_the_models_values(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, profile="sensing")
    imu = msgs.IMU
    key = topic_key(0, "/robot/uno/imu", imu, msgs.type_hash(imu))
    sequences: list[int] = []
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        running_bridge(imu_config(), {1: board}) as (port, _),
        sdk_peer(port) as peer,
    ):
        await peer.subscribe("/robot/uno/imu", imu)
        listener = await anyio.to_thread.run_sync(
            zenoh.open, zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])
        )

        def on_sample(sample: zenoh.Sample) -> None:
            assert sample.attachment is not None
            sequences.append(decode_attachment(sample.attachment.to_bytes()).sequence)

        try:
            subscriber = listener.declare_subscriber(key, on_sample)
            got = [await peer.message(lambda m: m.get("topic") == "/robot/uno/imu")
                   for _ in range(COUNT)]  # fmt: skip
            undeclare(subscriber)
        finally:
            await anyio.to_thread.run_sync(listener.close)
        state = await uno.command("imu")
        reads = await served(uno)
    # The helper set the ranges on the model.
    assert (state["accel_config"], state["gyro_config"]) == (1 << 3, 1 << 3)
    # Each message is one of the model's reads, in order, none left out: find the first.
    values = [datasheet(data) for _, data in reads]
    first = values.index((got[0]["accel"], got[0]["gyro"]))
    matched = reads[first : first + COUNT]
    assert [(m["accel"], m["gyro"]) for m in got] == values[first : first + COUNT]
    assert len({data for _, data in matched}) > COUNT // 2  # the model moves: a real check
    assert all(m["frame_id"] == "imu_link" for m in got)
    # 200 Hz of board (simulated) time: the reads are one period apart.
    read_us = [us for us, _ in matched]
    assert [b - a for a, b in itertools.pairwise(read_us)] == pytest.approx(
        [STREAM_MS * 1000] * (COUNT - 1), abs=100
    )
    # Stamps are in host time (the clock estimate maps the board's sample time): they
    # increase, none is after the SDK got its message (beyond the estimate's documented
    # spread), and once the estimate has its buckets (the second half of the run) the
    # median stamp is within the documented spread plus the edge -> subscriber p99 of its
    # receipt (single messages wait longer in the loaded SDK process: not a stamp error).
    stamps = [m["stamp_ns"] for m in got]
    assert all(b > a for a, b in itertools.pairwise(stamps))
    lags = [m["received_ns"] - m["stamp_ns"] for m in got]
    assert min(lags) >= -STAMP_ERROR_NS, min(lags)
    settled = lags[COUNT // 2 :]
    assert statistics.median(settled) <= STAMP_ERROR_NS + LATENCY_P99_NS, sorted(settled)
    # Consecutive sequence numbers on the wire (the raw subscriber came after the SDK's).
    assert len(sequences) >= COUNT // 2
    assert sequences == list(range(sequences[0], sequences[0] + len(sequences)))
