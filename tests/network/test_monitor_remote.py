"""``arduinoio monitor --remote``: the live page for a board served on the network."""

from __future__ import annotations

import json
import socket
import subprocess
import sys

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
            finally:
                process.terminate()
                with anyio.move_on_after(5):
                    await process.wait()
