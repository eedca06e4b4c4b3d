"""``arduinoio ros2 --config FILE`` as a user runs it: its own process, a virtual Uno found
through ``--ports``, and the independent ROS 2 peer toggling D2 and hearing D3."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import anyio
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import DEADLINE, free_port, sdk_peer

pytest.importorskip("zenoh_ros2_sdk")

CONFIG = """\
namespace: /robot
boards:
  - name: uno
    id: 0x0001
    inputs: [{pin: D3, type: bool, topic: d3}]
    outputs: [{pin: D2, type: bool, topic: d2}]
"""


@pytest.mark.sim
async def test_the_command_serves_a_board_as_a_ros_node(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    config = tmp_path / "robot.yaml"
    config.write_text(CONFIG)
    port = free_port()
    command = [
        sys.executable, "-m", "arduinoio_async", "ros2", "--config", str(config),
        "--no-usb", "--ports", uno.port, "--baud", str(uno.baud),
        "--listen", f"tcp/127.0.0.1:{port}",
    ]  # fmt: skip
    async with await anyio.open_process(command) as bridge:
        try:
            assert bridge.stdout is not None
            with anyio.fail_after(DEADLINE):
                ready = await BufferedByteReceiveStream(bridge.stdout).receive_until(b"\n", 4096)
            assert json.loads(ready)["nodes"] == ["/robot/uno"]
            async with sdk_peer(port) as peer:
                await peer.subscribe("/robot/uno/d3", "std_msgs/msg/Bool")
                await peer.publish("/robot/uno/d2", "std_msgs/msg/Bool", True)
                await peer.message(lambda m: m.get("topic") == "/robot/uno/d3" and m["data"])
                assert (await uno.pin(2)).level == 1
        finally:
            bridge.terminate()
