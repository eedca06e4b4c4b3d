"""``arduinoio ros2 --config FILE`` as a user runs it: its own process, a virtual Uno found
through ``--ports``, and the independent ROS 2 peer toggling D2 and hearing D3."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import anyio
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import DEADLINE, Peer, free_port, sdk_peer

pytest.importorskip("zenoh_ros2_sdk")

CONFIG = """\
namespace: /robot
boards:
  - name: uno
    id: 0x0001
    inputs: [{pin: D3, type: bool, topic: d3}]
    outputs: [{pin: D2, type: bool, topic: d2}]
"""


async def command_until_heard(peer: Peer, level: bool) -> None:
    """Publish ``level`` on D2 every half second, as a controller repeats its command, until
    D3 reports it (a command that meets the board away is dropped, not queued).  What came
    before is forgotten: messages arrive in order, so a match is the answer to this level."""
    peer.messages.clear()
    with anyio.fail_after(DEADLINE):
        while True:
            await peer.publish("/robot/uno/d2", "std_msgs/msg/Bool", level)
            with anyio.move_on_after(0.5):
                await peer.message(
                    lambda m: m.get("topic") == "/robot/uno/d3" and m["data"] is level
                )
                return


@pytest.mark.sim
async def test_the_command_serves_a_board_as_a_ros_node(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    config = tmp_path / "robot.yaml"
    config.write_text(CONFIG)
    port = free_port()
    # The board's port through a symlink the manager globs, as a udev rule would give it,
    # so the replugged board (a new pseudo-terminal) is found under the same name.
    link = tmp_path / "uno-0001"
    link.symlink_to(uno.port)
    command = [
        sys.executable, "-m", "arduinoio_async", "ros2", "--config", str(config),
        "--no-usb", "--ports", str(tmp_path / "uno-*"), "--baud", str(uno.baud),
        "--listen", f"tcp/127.0.0.1:{port}",
    ]  # fmt: skip
    log = (tmp_path / "bridge.log").open("wb")
    # Only the named port: not the virtual Unos other tests announce in the registry.
    env = {**os.environ, "ARDUINOIO_REGISTRY_DIR": str(tmp_path)}
    env.pop("ARDUINOIO_PORTS", None)
    async with await anyio.open_process([*command, "-v"], stderr=log, env=env) as bridge:
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
                # Unplug and replug: the manager re-adopts the board, the bridge goes on.
                await uno.unplug()
                await uno.replug()
                fresh = tmp_path / "uno-0001.new"
                fresh.symlink_to(uno.port)
                fresh.replace(link)
                for level in (False, True):
                    await command_until_heard(peer, level)
                assert (await uno.pin(2)).level == 1
        finally:
            bridge.terminate()
            log.close()
            print((tmp_path / "bridge.log").read_text())


def test_a_wrong_config_or_a_missing_board_is_one_line_and_exit_1(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from arduinoio_async.cli import main

    monkeypatch.setenv("ARDUINOIO_REGISTRY_DIR", str(tmp_path))  # no other virtual Unos
    monkeypatch.delenv("ARDUINOIO_PORTS", raising=False)
    bad = tmp_path / "bad.yaml"
    bad.write_text("boards:\n  - {name: a, id: 1, outputs: [{pin: D3, type: servo, topic: s}]}\n")
    assert main(["ros2", "--config", str(bad)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"error: {bad}: boards[0].outputs[0].pin: D3 cannot be a 'servo' (D9, D10 can)"]
    good = tmp_path / "good.yaml"
    good.write_text("boards:\n  - {name: a, id: 0x0042}\n")
    assert main(["ros2", "--config", str(good), "--no-usb", "--wait", "0.2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: no board with ID 0x0042 found")
