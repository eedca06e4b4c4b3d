"""A board stand-in that answers instantly, for measuring the host's own cost.

:class:`InstantStream` answers inside ``send`` (no task switch, a dict lookup), so a
benchmark against it measures only the library.  :func:`pty_responder`
(``python -m arduinoio_async.bench.responder FD [INTERVAL]``) does the same on a
pseudo-terminal master in a separate process, so the client's CPU time can be measured
apart from the responder's, and can pace its replies like a firmware's command rate: the
one pty responder of ``arduinoio bench --host`` and ``benchmarks/fast_link.py``.
"""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time
import tty
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import fields
from typing import Any

import anyio
import anyio.abc

from .. import protocol as p
from ..transport import ImmediateSender
from .commands import COMMANDS

__all__ = ["InstantStream", "pty_responder", "serve_fd"]


def _reply_table() -> dict[bytes, bytes]:
    """Request bytes -> reply bytes for every benchmark command (and the handshake)."""
    table = {c.request.encode(): c.reply.encode() for c in COMMANDS}
    table[p.ReadCapabilities().encode()] = p.ReadCapabilitiesReply(
        p.PROTOCOL_VERSION, *p.FIRMWARE_VERSION, 0x3FF, p.DEFAULT_BAUD, p.RX_FIFO_SIZE
    ).encode()
    table[p.ReadStatus().encode()] = p.ReadStatusReply(p.StatusFlags.NONE, 0).encode()
    return table


class InstantStream(anyio.abc.ByteStream, ImmediateSender):
    """Replies are ready the moment a request is sent; SetSession is echoed."""

    def __init__(self) -> None:
        self._table = _reply_table()
        self._replies: deque[bytes] = deque()
        self._ready = anyio.Event()

    async def send(self, item: bytes) -> None:
        self.send_nowait(item)

    def send_nowait(self, item: bytes) -> None:
        reply = self._table.get(bytes(item))
        if reply is None:
            decoded = p.Decoder.from_host().feed(item)
            request = decoded[0]
            assert isinstance(request, p.SetSession)
            reply = p.SetSessionReply(request.session).encode()
        self._replies.append(reply)
        self._ready.set()

    async def receive(self, max_bytes: int = 65536) -> bytes:
        while not self._replies:
            self._ready = anyio.Event()
            await self._ready.wait()
        return self._replies.popleft()

    async def send_eof(self) -> None:
        pass

    async def aclose(self) -> None:
        pass


def serve_fd(fd: int, interval: float = 0.0) -> None:
    """A board stand-in on pty master ``fd`` until it closes (run it as a child process):
    the handshake and the benchmark commands from the reply table, and every other request
    whose reply echoes its fields (GPIO configure and write, SetSession) by echoing them.

    ``interval`` 0: answers at once, the replies to all the requests one read brought in
    one write.  Otherwise like a board whose firmware takes ``interval`` seconds per
    command: each reply in its own write, ``interval`` after the previous one (or when
    its request arrives, if later); the wait is a busy loop, as a sleep would wake tens
    of microseconds late.
    """
    table = _reply_table()
    decoder = p.Decoder.from_host()
    due: deque[bytes] = deque()
    next_at = 0.0
    os.set_blocking(fd, interval == 0)
    while True:
        try:
            data = os.read(fd, 65536)
        except BlockingIOError:
            data = None
        except OSError:
            return
        if data == b"":
            return
        if data:
            due.extend(
                _reply(table, frame) for frame in decoder.feed(data) if isinstance(frame, p.Request)
            )
        if interval == 0:
            if due:
                os.write(fd, b"".join(due))
                due.clear()
            continue
        now = time.perf_counter()
        if not due:
            next_at = max(next_at, now)
            select.select([fd], [], [], 0.05)
            continue
        if now >= next_at:
            os.write(fd, due.popleft())
            next_at = max(next_at + interval, now - interval)


def _reply(table: dict[bytes, bytes], request: p.Request[Any]) -> bytes:
    """The table's reply, else (remembered in the table) the request's fields echoed."""
    raw = request.encode()
    reply = table.get(raw)
    if reply is None:
        echoed = [getattr(request, f.name) for f in fields(request)]  # type: ignore[arg-type]
        reply = table[raw] = request.REPLY(*echoed).encode()
    return reply


@contextmanager
def pty_responder(interval: float = 0.0) -> Iterator[str]:
    """A :func:`serve_fd` child process on a fresh pseudo-terminal; yields the port's path."""
    master, slave = os.openpty()
    child = subprocess.Popen(
        [sys.executable, "-m", __name__, str(master), str(interval)], pass_fds=(master,)
    )
    os.close(master)
    try:
        _wait_until_answering(slave)
        yield os.ttyname(slave)
    finally:
        os.close(slave)
        child.terminate()
        child.wait()


def _wait_until_answering(slave: int, within: float = 30.0) -> None:
    """One Read ID through the pty (raw mode, as every client sets): a loaded machine can
    take seconds to start the child, and a client's first read must not time out on it."""
    tty.setraw(slave)
    os.write(slave, p.ReadId().encode())
    want = len(p.ReadIdReply(0).encode())
    got = b""
    deadline = time.monotonic() + within
    while len(got) < want:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([slave], [], [], left)[0]:
            raise RuntimeError(f"the pty responder did not answer within {within:g} s")
        got += os.read(slave, want - len(got))


if __name__ == "__main__":
    serve_fd(int(sys.argv[1]), float(sys.argv[2]) if len(sys.argv) > 2 else 0.0)
