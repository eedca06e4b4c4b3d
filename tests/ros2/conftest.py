"""A bridge on a loopback Zenoh endpoint and the independent ROS 2 peer in its own process."""

from __future__ import annotations

import json
import socket
import sys
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import anyio.abc
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

pytest.importorskip("zenoh")
pytest.importorskip("rosbags")

import zenoh

from arduinoio_async.network import zenoh_config
from arduinoio_async.ros2 import BoardNode, BridgeConfig, run_bridge

PEER = Path(__file__).with_name("sdk_peer.py")
#: Seconds a message, a graph query or a peer start may take on a loaded machine.
DEADLINE = 20.0


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


class Peer:
    """zenoh-ros2-sdk in a separate process (tests/ros2/sdk_peer.py), line by line."""

    def __init__(self, process: anyio.abc.Process) -> None:
        assert process.stdin is not None and process.stdout is not None
        self.process = process
        self._stdin = process.stdin
        self._lines = BufferedByteReceiveStream(process.stdout)
        #: Messages received on subscribed topics, in order.
        self.messages: list[dict[str, Any]] = []

    async def _send(self, order: dict[str, Any]) -> None:
        await self._stdin.send((json.dumps(order) + "\n").encode())

    async def _next(self) -> dict[str, Any]:
        with anyio.fail_after(DEADLINE):
            line = await self._lines.receive_until(b"\n", 1 << 20)
        item: dict[str, Any] = json.loads(line)
        return item

    async def _answer(self, op: str) -> dict[str, Any]:
        while True:
            item = await self._next()
            if item.get("op") == op:
                return item
            self.messages.append(item)

    async def subscribe(self, topic: str, ros_type: str) -> None:
        await self._send({"op": "sub", "topic": topic, "type": ros_type})
        await self._answer("subscribed")

    async def publish(self, topic: str, ros_type: str, data: Any) -> None:
        await self._send({"op": "pub", "topic": topic, "type": ros_type, "data": data})
        await self._answer("published")

    async def topics(self) -> dict[str, list[str]]:
        await self._send({"op": "topics"})
        return {name: types for name, types in (await self._answer("topics"))["topics"]}

    async def info(self, topic: str) -> dict[str, Any]:
        await self._send({"op": "info", "topic": topic})
        return await self._answer("info")

    async def message(self, where: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
        """The first message (already received or next) for which ``where`` holds."""
        for item in self.messages:
            if where(item):
                self.messages.remove(item)
                return item
        while True:
            item = await self._next()
            if where(item):
                return item
            self.messages.append(item)


@asynccontextmanager
async def running_bridge(
    config: BridgeConfig, boards: Mapping[int, Any]
) -> AsyncIterator[tuple[int, list[BoardNode]]]:
    """The bridge on a fresh loopback port: yields the port and the nodes."""
    port = free_port()
    zconfig = zenoh_config(listen=[f"tcp/127.0.0.1:{port}"])
    session = await anyio.to_thread.run_sync(zenoh.open, zconfig)
    try:
        async with anyio.create_task_group() as tg:
            nodes = await tg.start(run_bridge, session, config, boards)
            yield port, nodes
            tg.cancel_scope.cancel()
    finally:
        await anyio.to_thread.run_sync(session.close)


@asynccontextmanager
async def sdk_peer(port: int) -> AsyncIterator[Peer]:
    async with await anyio.open_process([sys.executable, str(PEER), str(port)]) as process:
        try:
            yield Peer(process)
        finally:
            process.kill()
