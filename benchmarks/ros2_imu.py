"""The streamed IMU to a ROS 2 subscriber at 1 kHz: messages lost (issue 30).

A virtual Uno (sensing image, no 16U2 model, 1 Mbaud) with its MPU-6050 model streams
the IMU's register block every 1 ms; the bridge publishes one ``sensor_msgs/Imu`` per
sample; zenoh-ros2-sdk in a separate process (``tests/ros2/sdk_peer.py``) subscribes.
Lost = the messages the bridge published with stamps from the first to the last one the
SDK received in the window, minus the messages the SDK received.  The board streams
1 kHz of its own time; the simulator runs slower than the wall clock on a loaded machine,
so ``rate_hz_host_time`` (messages per second of stamps) is below 1,000 there.
The result is merged into ``benchmarks/results/ros2.json`` under ``imu_stream``:

    .venv/bin/python -m benchmarks.ros2_imu --seconds 60 --json benchmarks/results/ros2.json
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import time
from pathlib import Path
from typing import Any

import anyio
import zenoh

from arduinoio_async.board import Board
from arduinoio_async.network import zenoh_config
from arduinoio_async.ros2 import parse, run_bridge
from arduinoio_async.sim import VirtualUno
from benchmarks._results import command_line, merge_result
from tests.ros2.conftest import free_port, sdk_peer

TOPIC = "/uno/imu"
CONFIG = {
    "boards": [{"name": "uno", "id": 1, "stream_ms": 1,
                "inputs": [{"type": "imu", "topic": "imu"}]}]
}  # fmt: skip


async def main(args: argparse.Namespace) -> dict[str, Any]:
    port = free_port()
    session = await anyio.to_thread.run_sync(
        zenoh.open, zenoh_config(listen=[f"tcp/127.0.0.1:{port}"])
    )
    try:
        async with (
            VirtualUno(board_id=1, usb_bridge="none", baud=1_000_000, profile="sensing") as uno,
            Board.open(uno.port, baudrate=uno.baud) as board,
            anyio.create_task_group() as tg,
        ):
            nodes = await tg.start(run_bridge, session, parse(CONFIG), {1: board})
            async with sdk_peer(port) as peer:
                await peer.subscribe(TOPIC, "sensor_msgs/msg/Imu")
                with anyio.fail_after(30):  # warm-up: the first message arrived
                    await peer.message(lambda m: m.get("topic") == TOPIC)
                stream = nodes[0].stream
                assert stream is not None
                sent: list[int] = []  # the stamp of every Imu the bridge put
                put = stream._put

                def counting_put(publisher: Any, payload: bytes) -> None:
                    sec, nanosec = struct.unpack_from("<iI", payload, 4)  # CDR LE header
                    sent.append(sec * 1_000_000_000 + nanosec)
                    put(publisher, payload)

                stream._put = counting_put
                got: list[int] = []  # the stamp of every Imu the SDK received
                started = time.monotonic()
                while time.monotonic() - started < args.seconds:
                    item = await peer._next()
                    if item.get("topic") == TOPIC:
                        got.append(item["stamp_ns"])
            tg.cancel_scope.cancel()
    finally:
        await anyio.to_thread.run_sync(session.close)
    # The window: from the first message counted on the way out to the last one received.
    first, last = sent[0], got[-1]
    published = sum(1 for stamp in sent if first <= stamp <= last)
    received = sum(1 for stamp in got if first <= stamp <= last)
    return {
        "command": command_line(),
        "machine": f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end",
        "link": "virtual Uno (sensing image), no 16U2 model, 1,000,000 baud; Zenoh TCP loopback",
        "load": "one MPU-6050 14-byte block at 400 kHz I2C every 1 ms; no other stream input",
        "seconds_wall": args.seconds,
        "stamped_span_s": round((last - first) / 1e9, 3),
        "published": published,
        "received_by_sdk": received,
        "lost": published - received,
        "rate_hz_host_time": round(received / ((last - first) / 1e9), 1),
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(main, args)
    print(json.dumps(result, indent=2))
    if args.json is not None:
        merge_result(args.json, lambda data: data.__setitem__("imu_stream", result))
