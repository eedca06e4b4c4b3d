"""A board stand-in that answers instantly, for measuring the host's own cost.

:class:`InstantStream` answers inside ``send`` (no task switch, a dict lookup), so a
benchmark against it measures only the library.  ``python -m
arduinoio_async.bench.responder FD`` does the same on a pseudo-terminal master in a
separate process, so the client's CPU time can be measured apart from the responder's.
"""

from __future__ import annotations

import os
import sys
from collections import deque

import anyio
import anyio.abc

from .. import protocol as p
from ..transport import ImmediateSender
from .commands import COMMANDS

__all__ = ["InstantStream", "reply_table"]


def reply_table() -> dict[bytes, bytes]:
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
        self._table = reply_table()
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


def serve_fd(fd: int) -> None:
    """Answer requests on ``fd`` until it closes (child process of the host benchmark)."""
    table = reply_table()
    decoder = p.Decoder.from_host()
    while True:
        try:
            data = os.read(fd, 4096)
        except OSError:
            return
        if not data:
            return
        out = b"".join(
            table.get(frame.encode(), b"")
            for frame in decoder.feed(data)
            if isinstance(frame, p.Frame)
        )
        if out:
            os.write(fd, out)


if __name__ == "__main__":
    serve_fd(int(sys.argv[1]))
