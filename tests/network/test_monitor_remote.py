"""``arduinoio monitor --remote``: the live page for a board served on the network."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import anyio
import pytest
from anyio.streams.text import TextReceiveStream

from .conftest import ServeFactory

pytestmark = pytest.mark.sim
ws_client = pytest.importorskip("websockets.asyncio.client")


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def control(page: Any, op: str, **args: Any) -> None:
    """One control request of the page, answered ok."""
    await page.send(json.dumps({"id": op, "board": "b0", "op": op, **args}))
    with anyio.fail_after(10):
        while True:
            message = json.loads(await page.recv())
            if message["type"] == "result" and message["id"] == op:
                assert message["ok"], message
                return


async def until_samples(page: Any, condition: Callable[[Any], bool]) -> Any:
    """The first samples message that satisfies ``condition``."""
    with anyio.fail_after(10):
        while True:
            message = json.loads(await page.recv())
            if message["type"] == "samples" and condition(message):
                return message


async def test_the_monitor_shows_a_remote_board_and_its_samples(serve_unos: ServeFactory) -> None:
    async with serve_unos([7], fixture="loopback") as served:
        await served.unos[7].set_analog(0, 2500.0)
        http = f"127.0.0.1:{free_port()}"
        command = [sys.executable, "-m", "arduinoio_async", "monitor", "--remote", "--id", "7"]
        command += ["--connect", served.endpoint, "--http", http]
        async with await anyio.open_process(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
        ) as process:
            try:
                assert process.stdout is not None
                output = ""
                with anyio.fail_after(30):
                    async for chunk in TextReceiveStream(process.stdout):
                        output += chunk
                        if f"http://{http}" in output:
                            break
                    else:
                        raise AssertionError(f"the monitor ended:\n{output}")
                async with ws_client.connect(f"ws://{http}/ws", proxy=None) as page:
                    seen: dict[str, dict[str, object]] = {}
                    with anyio.fail_after(10):
                        while not {"board", "samples"} <= seen.keys():
                            message = json.loads(await page.recv())
                            seen.setdefault(message["type"], message)
                    assert seen["board"]["id"] == 7 and seen["board"]["connected"] is True
                    # Change events travel over the network: D2 -> jumper -> D3 (input),
                    # whose level and edge count come from the events the server relays.
                    await control(page, "role", pin="D3", role="input")
                    await control(page, "role", pin="D2", role="output")
                    await until_samples(page, lambda m: m["watched"] == 1 << 3)
                    await control(page, "write", pin="D2", value=1)
                    await control(page, "write", pin="D2", value=0)
                    last = await until_samples(page, lambda m: m["falls"][3 - 2] == 1)
                    assert last["rises"][3 - 2] == 1 and not last["levels"] & 1 << 3
                    assert last["changes"]["received"] == 2 and last["changes"]["lost"] == 0
            finally:
                process.terminate()
                with anyio.move_on_after(5):
                    await process.wait()
