"""The fake board's end of the link: framing, filler, faults, whole frames only.

Every frame the fake board sends -- a reply, an event, a stream sample -- leaves through
:meth:`FakeWire._send`: reframed in the framing in force, padded with the low-latency
filler (replies only), then passed through the configured :class:`~._faults.Faults`
(delay, corruption, split chunks) under one lock, so frames never interleave, as on the
firmware's transmit ring.
"""

from __future__ import annotations

import random

import anyio
import anyio.lowlevel
from anyio.streams.memory import MemoryObjectReceiveStream

from .. import protocol as p
from ..transport import MemoryByteStream
from ._faults import Faults, corrupt
from ._timed import StreamModel

__all__ = ["FakeWire"]


class FakeWire:
    """Sending frames to the host (mixed into the FakeBoard)."""

    faults: Faults
    framing: p.Framing
    low_latency: bool
    filler_sent: int
    corrupted_replies: int
    stream: StreamModel
    _random: random.Random
    _reply_framing: p.Framing | None
    _send_lock: anyio.Lock
    _board_stream: MemoryByteStream
    _changes_out: MemoryObjectReceiveStream[p.Event]

    def _framed(self, frame: bytes, framing: p.Framing | None = None) -> bytes:
        """An XOR-framed frame in the framing in force (or in ``framing``)."""
        return p.crc_framed(frame) if (framing or self.framing) is p.Framing.CRC16 else frame

    async def _send(self, stream: MemoryByteStream, frame: bytes, pad: bool = False) -> None:
        """Send ``frame`` (XOR-framed: reframed here), padded with filler if ``pad`` (a
        reply), through the faults."""
        if pad:
            framing, self._reply_framing = self._reply_framing, None
            frame = self._padded(self._framed(frame, framing))
        else:
            frame = self._framed(frame)
        faults, rnd = self.faults, self._random
        low, high = faults.delay
        if high > 0:
            await anyio.sleep(rnd.uniform(low, high))
        out = bytearray(corrupt(frame, faults, rnd))
        if bytes(out) != frame:
            self.corrupted_replies += 1
        async with self._send_lock:
            if not faults.split:
                await stream.send(bytes(out))
                return
            while out:
                cut = rnd.randint(1, len(out))
                await stream.send(bytes(out[:cut]))
                del out[:cut]
                await anyio.lowlevel.checkpoint()

    def _padded(self, reply: bytes) -> bytes:
        """``reply`` followed by the filler the firmware sends in low-latency mode (none
        while a stream runs)."""
        if not self.low_latency or self.stream.running or len(reply) >= p.LOW_LATENCY_PAD:
            return reply
        filler = p.LOW_LATENCY_PAD - len(reply)
        self.filler_sent += filler
        return reply + bytes([p.FILLER]) * filler

    async def _send_changes(self) -> None:
        async for event in self._changes_out:
            try:
                await self._send(self._board_stream, event.encode())
            except (anyio.BrokenResourceError, anyio.ClosedResourceError):
                return
