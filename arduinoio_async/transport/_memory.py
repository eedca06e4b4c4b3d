"""An in-memory byte link: two connected anyio byte streams for tests and fakes."""

from __future__ import annotations

import math

import anyio
import anyio.abc
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from ._streams import ImmediateSender

__all__ = ["MemoryByteStream", "memory_link"]


class MemoryByteStream(anyio.abc.ByteStream, ImmediateSender):
    """One end of a :func:`memory_link`; chunks arrive as they were sent."""

    def __init__(
        self, send: MemoryObjectSendStream[bytes], receive: MemoryObjectReceiveStream[bytes]
    ) -> None:
        self._send = send
        self._receive = receive
        self._rest = b""

    async def receive(self, max_bytes: int = 65536) -> bytes:
        if not self._rest:
            try:
                self._rest = await self._receive.receive()
            except anyio.EndOfStream:
                raise anyio.BrokenResourceError("memory link closed by peer") from None
        data, self._rest = self._rest[:max_bytes], self._rest[max_bytes:]
        return data

    def send_nowait(self, item: bytes) -> None:
        """Queue ``item`` for the peer without suspending (the buffer is unbounded)."""
        try:
            self._send.send_nowait(bytes(item))
        except (anyio.ClosedResourceError, anyio.BrokenResourceError):
            raise anyio.BrokenResourceError("memory link closed") from None

    async def send(self, item: bytes) -> None:
        self.send_nowait(item)

    async def send_eof(self) -> None:
        await self._send.aclose()

    async def aclose(self) -> None:
        await self._send.aclose()
        await self._receive.aclose()


def memory_link() -> tuple[MemoryByteStream, MemoryByteStream]:
    """Two byte streams; what one sends the other receives (unbounded buffering)."""
    a_send, b_receive = anyio.create_memory_object_stream[bytes](math.inf)
    b_send, a_receive = anyio.create_memory_object_stream[bytes](math.inf)
    return MemoryByteStream(a_send, a_receive), MemoryByteStream(b_send, b_receive)
