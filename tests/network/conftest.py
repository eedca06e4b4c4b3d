"""A served virtual Uno: ``arduinoio serve`` in its own process, clients in others.

Each board's port is reached through a symlink ``<tmp>/uno-<id>`` that the server finds
with a glob pattern, so a replugged board (a new pseudo-terminal) is found again when a
test points the link at its new port.
"""

from __future__ import annotations

import itertools
import json
import os
import socket
import sys
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path

import anyio
import anyio.abc
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async import protocol as p
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytest.importorskip("zenoh")

SERVER_START_TIMEOUT = 20.0


def free_endpoint() -> str:
    """A loopback TCP endpoint nobody listens on now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


@dataclass
class Served:
    """Virtual Unos behind a running ``arduinoio serve``."""

    unos: dict[int, VirtualUno]
    endpoint: str
    ports_dir: Path
    command: list[str]
    env: dict[str, str]
    server: anyio.abc.Process = field(init=False)

    async def start(self) -> list[str]:
        """Start the server (again, after ``stop``); return the boards it serves at once."""
        self.server = await anyio.open_process(self.command, env=self.env, stderr=None)
        assert self.server.stdout is not None
        with anyio.fail_after(SERVER_START_TIMEOUT):
            line = await BufferedByteReceiveStream(self.server.stdout).receive_until(b"\n", 4096)
        serving: list[str] = json.loads(line)["serving"]
        return serving

    async def kill(self) -> None:
        """SIGKILL the server, as a crash would end it."""
        self.server.kill()
        await self.server.wait()

    def link_port(self, board_id: int) -> None:
        """Point the board's symlink at its current port (after a replug)."""
        link = self.ports_dir / f"uno-{board_id:04x}"
        fresh = link.with_suffix(".new")
        fresh.symlink_to(self.unos[board_id].port)
        fresh.replace(link)

    def unlink_port(self, board_id: int) -> None:
        (self.ports_dir / f"uno-{board_id:04x}").unlink()


ServeFactory = Callable[..., AbstractAsyncContextManager[Served]]


@pytest.fixture
def serve_unos(virtual_uno_factory: VirtualUnoFactory, tmp_path: Path) -> ServeFactory:
    """``async with serve_unos([7], baud=...) as served:`` -- boards and a server."""
    servers = itertools.count()

    @asynccontextmanager
    async def serve(
        ids: list[int], *, server_args: tuple[str, ...] = (), **uno_options: object
    ) -> AsyncIterator[Served]:
        ports_dir = tmp_path / f"ports-{next(servers)}"  # one per server
        ports_dir.mkdir()
        unos = {bid: await virtual_uno_factory(board_id=bid, **uno_options) for bid in ids}
        endpoint = free_endpoint().replace("tcp/", "tls/" if "--config" in server_args else "tcp/")
        baud = int(str(uno_options.get("baud", p.DEFAULT_BAUD)))
        env = {k: v for k, v in os.environ.items() if k != "ARDUINOIO_PORTS"}
        command = [sys.executable, "-m", "arduinoio_async", "serve", "--no-usb"]
        command += ["--ports", str(ports_dir / "uno-*"), "--baud", str(baud)]
        command += ["--listen", endpoint, "--rescan", "0.2", *server_args]
        for bid, uno in unos.items():
            (ports_dir / f"uno-{bid:04x}").symlink_to(uno.port)
        served = Served(unos, endpoint, ports_dir, command, env)
        try:
            assert await served.start() == [f"0x{bid:04X}" for bid in sorted(ids)]
            yield served
        finally:
            if hasattr(served, "server"):
                with anyio.CancelScope(shield=True):
                    served.server.terminate()
                    with anyio.move_on_after(5):
                        await served.server.wait()
                    if served.server.returncode is None:
                        served.server.kill()
                        await served.server.wait()

    return serve
