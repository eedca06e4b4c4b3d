"""Serving the monitor for boards you already hold: the CLI and the tests both use this.

``async with serve_monitor([board], http="127.0.0.1:0") as server: print(server.url)``
runs the hub and a uvicorn server in the caller's event loop until the block exits.  The
socket is bound before the block starts, so ``server.url`` works at once (a port of 0
picks a free one).
"""

from __future__ import annotations

import ipaddress
import logging
import secrets
import socket
from collections.abc import AsyncIterator, Iterator, Sequence
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

import anyio
import uvicorn

from ..errors import UsageError
from ._app import create_app, missing_assets
from ._hub import MonitorHub

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["DEFAULT_HTTP", "MonitorServer", "is_loopback", "parse_http", "serve_monitor"]

logger = logging.getLogger(__name__)

DEFAULT_HTTP = "127.0.0.1:8000"
#: Seconds open page connections get to close when the monitor stops.
SHUTDOWN_GRACE = 1


def parse_http(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (IPv6 in brackets) to a host and a port."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise UsageError(f"--http wants HOST:PORT like {DEFAULT_HTTP}, got {text!r}")
    return host.strip("[]"), int(port)


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name: it may resolve anywhere


def new_token() -> str:
    """A random access token (144 bits, URL-safe) for a monitor served beyond loopback."""
    return secrets.token_urlsafe(18)


@dataclass(frozen=True)
class MonitorServer:
    """A running monitor: its hub and the URL to open (with the token, if any)."""

    hub: MonitorHub
    host: str
    port: int
    token: str | None

    @property
    def url(self) -> str:
        """The page's address to open in a browser, with the token if there is one."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        query = f"?token={self.token}" if self.token else ""
        return f"http://{host}:{self.port}/{query}"


class _Server(uvicorn.Server):
    """uvicorn without its own signal handling: the caller owns the process's signals
    (``arduinoio monitor`` stops on SIGINT/SIGTERM; a test or robot program decides itself).
    """

    @contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield


def _bind(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(64)
        sock.setblocking(False)
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot serve on {host}:{port}: {exc.strerror or exc}") from exc
    return sock


@asynccontextmanager
async def serve_monitor(
    boards: Sequence[Board],
    *,
    http: str = DEFAULT_HTTP,
    token: str | None = None,
    period_ms: float = 20.0,
    stream: bool = True,
) -> AsyncIterator[MonitorServer]:
    """Serve the monitor page for ``boards`` until the block exits.

    Bound to a loopback address no token is needed (one may still be given); bound to
    any other address a token is required (:func:`new_token` makes a good one).
    ``stream=False`` leaves the board's sample stream off: the inputs still follow their
    change events, but there are no analog plots and no levels of outputs.
    """
    host, port = parse_http(http)
    loopback = is_loopback(host)
    if not loopback and not token:
        raise UsageError(f"serving on {host} (not loopback) needs a token")
    missing = missing_assets()
    if missing:
        raise UsageError(
            f"the monitor's browser files are not installed ({', '.join(missing)}): "
            "run `make monitor-assets` in the source tree (needs npm)"
        )
    if not boards:
        raise UsageError("no boards to monitor")
    hub = MonitorHub(boards, period_ms=period_ms, stream=stream)
    app = create_app(hub, token=token, loopback=loopback)
    sock = _bind(host, port)
    config = uvicorn.Config(
        app,
        log_level="warning",
        lifespan="off",
        ws="websockets-sansio",
        timeout_graceful_shutdown=SHUTDOWN_GRACE,
    )
    server = _Server(config)
    running = MonitorServer(hub, host, sock.getsockname()[1], token)
    served = anyio.Event()

    async def serve() -> None:
        try:
            await server.serve([sock])
        finally:
            served.set()

    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(hub.run)
            tg.start_soon(serve)
            try:
                yield running
            finally:
                server.should_exit = True  # uvicorn closes the pages' connections
                with anyio.move_on_after(SHUTDOWN_GRACE + 2):
                    await served.wait()
                tg.cancel_scope.cancel()
    finally:
        sock.close()
