"""An independent ROS 2 peer in its own process: zenoh-ros2-sdk (PyPI, by ROBOTIS).

It speaks rmw_zenoh without a ROS install, and nobody on this project wrote it, so a
message it decodes proves the bridge's key expressions, RIHS01 hashes, CDR and tokens
as that implementation reads them (it computes the type hash from the message text
itself: a different hash would route nothing).  Driven by JSON lines on stdin, it answers
with JSON lines on stdout:

    {"op": "sub", "topic": "/robot/uno/d3", "type": "std_msgs/msg/Bool"}
        -> {"op": "subscribed"}; later {"topic": ..., "data": ..., "received_ns": ...}
    {"op": "pub", "topic": ..., "type": ..., "data": true}  -> {"op": "published"}
    {"op": "topics"}  -> {"op": "topics", "topics": [[name, [types]], ...]}
    {"op": "info", "topic": ...}  -> {"op": "info", "publishers": [[ns, node], ...], ...}
    {"op": "echo"}  -> {"op": "echoing"}; then every sample on bench/ping is put back on
        bench/pong (the plain Zenoh round trip the ROS latency is compared with)

``python sdk_peer.py PORT`` connects to the bridge's Zenoh endpoint on 127.0.0.1:PORT.
"""

from __future__ import annotations

import json
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import zenoh_ros2_sdk as sdk  # type: ignore[import-untyped]  # no type information
from zenoh_ros2_sdk.message_registry import get_registry  # type: ignore[import-untyped]

#: The message texts the SDK would otherwise fetch from GitHub (common_interfaces).
DEFINITIONS = {
    "std_msgs/msg/Bool": "bool data\n",
    "std_msgs/msg/Float32": "float32 data\n",
    "std_msgs/msg/Float64": "float64 data\n",
    "std_msgs/msg/Int64": "int64 data\n",
}

#: Nested types: the SDK resolves a message's field types from .msg files in its registry's
#: directory (else it would clone common_interfaces from GitHub); these are ROS 2 Jazzy's.
NESTED = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n"
    ),
    "geometry_msgs/msg/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "sensor_msgs/msg/Imu": (
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
        "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
        "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
        "float64[9] linear_acceleration_covariance\n"
    ),
}
for _name in ("sensor_msgs/msg/JointState", "sensor_msgs/msg/Imu"):
    DEFINITIONS[_name] = NESTED[_name]

_out = threading.Lock()


def local_definitions() -> None:
    """Give the SDK's registry a directory with the nested types' .msg files."""
    root = Path(tempfile.mkdtemp(prefix="sdk-msgs-"))
    for name, text in NESTED.items():
        path = root / f"{name}.msg"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    get_registry(str(root))


def fields(message: Any) -> dict[str, Any]:
    """What the test compares: ``data``, or a JointState's or an Imu's fields and stamp."""
    if hasattr(message, "data"):
        return {"data": message.data}
    stamp = message.header.stamp
    if hasattr(message, "linear_acceleration"):
        a, w = message.linear_acceleration, message.angular_velocity
        return {
            "accel": [float(a.x), float(a.y), float(a.z)],
            "gyro": [float(w.x), float(w.y), float(w.z)],
            "frame_id": message.header.frame_id,
            "stamp_ns": stamp.sec * 1_000_000_000 + stamp.nanosec,
        }
    return {
        "name": list(message.name),
        "position": [float(x) for x in message.position],
        "velocity": [float(x) for x in message.velocity],
        "frame_id": message.header.frame_id,
        "stamp_ns": stamp.sec * 1_000_000_000 + stamp.nanosec,
    }


def say(item: dict[str, Any]) -> None:
    with _out:
        sys.stdout.write(json.dumps(item) + "\n")
        sys.stdout.flush()


def main() -> None:
    port = int(sys.argv[1])
    local_definitions()
    keep: list[Any] = []
    publishers: dict[str, Any] = {}
    for line in sys.stdin:
        order = json.loads(line)
        op = order["op"]
        if op == "sub":
            topic = order["topic"]
            if order["type"] in NESTED:  # its typestore learns the nested types first
                session = sdk.ZenohSession.get_instance(router_port=port)
                for name, text in NESTED.items():
                    session.register_message_type(text, name)

            def on_message(message: Any, topic: str = topic) -> None:
                say({"topic": topic, **fields(message), "received_ns": time.time_ns()})

            keep.append(
                sdk.ROS2Subscriber(
                    topic=topic,
                    msg_type=order["type"],
                    callback=on_message,
                    msg_definition=DEFINITIONS[order["type"]],
                    node_name="sdk_listener",
                    router_port=port,
                )
            )
            say({"op": "subscribed"})
        elif op == "pub":
            topic = order["topic"]
            if topic not in publishers:
                publishers[topic] = sdk.ROS2Publisher(
                    topic=topic,
                    msg_type=order["type"],
                    msg_definition=DEFINITIONS[order["type"]],
                    node_name="sdk_talker",
                    router_port=port,
                )
            publishers[topic].publish(data=order["data"])
            say({"op": "published"})
        elif op == "echo":  # plain Zenoh on the SDK's session: bench/ping -> bench/pong
            session = sdk.ZenohSession.get_instance(router_port=port).session
            pong = session.declare_publisher("bench/pong")

            def echo(sample: Any, pong: Any = pong) -> None:
                pong.put(sample.payload)

            keep += [pong, session.declare_subscriber("bench/ping", echo)]
            say({"op": "echoing"})
        elif op == "topics":
            found = sdk.get_topic_names_and_types(router_port=port, timeout=1.0)
            say({"op": "topics", "topics": [[name, types] for name, types in found]})
        elif op == "info":
            info = sdk.get_topic_info(order["topic"], router_port=port, timeout=1.0, verbose=True)
            say(
                {
                    "op": "info",
                    "publishers": [[e.node_namespace, e.node_name] for e in info.publishers]
                    if info
                    else [],
                    "subscribers": [[e.node_namespace, e.node_name] for e in info.subscribers]
                    if info
                    else [],
                }
            )


if __name__ == "__main__":
    main()
