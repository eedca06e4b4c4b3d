"""Incremental frame decoder: bytes in, frames out, never an exception for bad data.

Theory of operation: the decoder keeps unconsumed bytes in a buffer.  At the buffer's head
it asks "which frame can start here?": a known ``(CT, DT)`` pair gives the frame length
(plus the length byte's value for frames with a variable part), a class tag with the high
bit set gives a 4-byte error reply.  When the whole candidate is buffered its XOR must be
zero; then it is decoded and emitted.  Anything else -- an unknown tag, a bad checksum, a
field value its type forbids -- costs exactly one byte, which is reported as
:class:`Garbage`, and the search restarts at the next byte.  Skipping one byte (not the
whole candidate) is what lets a valid frame that begins inside a corrupt one be found.

An 8-bit checksum accepts a random candidate with probability 1/256, so after garbage a
spurious frame is possible; callers that see :class:`Garbage` should resynchronise (the
transport does: it fails what is in flight and confirms the board with an ID request).

*Filler* (an extension, ``SetLowLatency``): a board in low-latency mode sends bytes of
``FILLER`` (0x00) after its replies so that the Uno's USB bridge sends at once.  No frame
starts with 0x00 (no class tag is 0, and the error flag is clear), and a board sends
filler only between frames, so right after a frame (or at the start, or after
:meth:`Decoder.reset`) a ``from_board`` decoder drops a whole run of them, silently.
They cost nothing until the search for a frame start would have called them garbage;
inside a frame a 0x00 is data as before, and after garbage it is garbage too (the bytes
of a damaged frame are reported, never dropped, so the caller still resynchronises).

The same class decodes both directions: ``Decoder.from_board()`` (replies, error replies,
events) for the host, ``Decoder.from_host()`` (requests) for boards and test peers.  A
board frames by tags, length and checksum alone and refuses bad field values afterwards
(``VALUE_OUT_OF_RANGE``), so a board model asks ``from_host(keep_invalid=True)`` and gets
such a frame whole, as :class:`InvalidValues`, instead of one byte of garbage.

*CRC-16 framing* (an extension, ``SetFraming``): ``Decoder(..., framing=Framing.CRC16)``
expects every frame one byte longer, ending in the CRC-16/CCITT-FALSE of the bytes before
it (big-endian), and checks that instead of the XOR: the CRC of a whole valid frame is 0.
Frame lengths, fields and the search are the same; an error reply has 5 bytes.

*The common case, fast.*  Most chunks a host reads are exactly one reply.
:meth:`Decoder.whole_frame` takes that case alone, and remembers the frames it decoded by
their bytes (messages are immutable, so equal bytes can share one object): a board
answers the same few replies over and over -- write acknowledgements, IDs, levels -- and
a remembered frame costs one dict lookup instead of a checksum loop, an unpack and a
constructor.  :meth:`Decoder.feed` shares the memo for each candidate frame of a longer
chunk (many pipelined replies read at once).  The memo holds only valid frames (no error
replies), at most ``MEMO_SIZE`` of them, and starts afresh when full.
"""

from __future__ import annotations

import binascii
from collections.abc import Mapping
from dataclasses import dataclass

from ._constants import ERROR_FLAG, FILLER, ErrorCode, Framing
from ._layout import CRC16_INIT, Frame, Layout
from ._messages import EVENT_TYPES, REPLY_TYPES, REQUEST_TYPES, ErrorReply

__all__ = ["Decoded", "Decoder", "Garbage", "InvalidValues"]


@dataclass(frozen=True, slots=True)
class Garbage:
    """Bytes that did not form a valid frame, in the order they arrived."""

    data: bytes


@dataclass(frozen=True, slots=True)
class InvalidValues(Garbage):
    """A whole frame by tags, length and checksum whose field values its types forbid
    (an I2C speed of 2, say); only a ``keep_invalid`` decoder reports these."""

    @property
    def class_tag(self) -> int:
        """The frame's class tag (its first byte): which command class it belongs to."""
        return self.data[0]

    @property
    def descriptor(self) -> int:
        """The frame's descriptor (its second byte): which command within the class."""
        return self.data[1]


Decoded = Frame | Garbage

_FILLER_BYTE = bytes((FILLER,))


def _layouts(*tables: Mapping[tuple[int, int], type[Frame]]) -> dict[int, Layout]:
    return {(ct << 8) | dt: cls.LAYOUT for table in tables for (ct, dt), cls in table.items()}


class Decoder:
    """Turns arbitrary chunks of a byte stream into frames and garbage."""

    __slots__ = (
        "_accept_errors",
        "_aligned",
        "_buffer",
        "_crc",
        "_drop_filler",
        "_error_size",
        "_extra",
        "_first_bytes",
        "_keep_invalid",
        "_layouts",
        "_memo",
        "_pending_garbage",
    )

    #: Whole frames :meth:`whole_frame` remembers by their bytes.
    MEMO_SIZE = 512

    def __init__(
        self,
        layouts: dict[int, Layout],
        *,
        accept_errors: bool,
        keep_invalid: bool = False,
        drop_filler: bool = False,
        framing: Framing = Framing.XOR,
    ) -> None:
        self._layouts = layouts
        self._crc = framing is Framing.CRC16
        #: Bytes a frame has beyond its layout's sizes (the second CRC byte).
        self._extra = 1 if self._crc else 0
        self._error_size = ErrorReply.SIZE + self._extra
        self._drop_filler = drop_filler and FILLER not in {key >> 8 for key in layouts}
        self._aligned = True  # the last thing decoded was a frame: filler may follow
        self._accept_errors = accept_errors
        self._keep_invalid = keep_invalid
        self._buffer = bytearray()
        self._pending_garbage = bytearray()
        self._first_bytes = frozenset(key >> 8 for key in layouts)
        self._memo: dict[bytes, Frame] = {}

    @classmethod
    def from_board(cls, *, drop_filler: bool = True, framing: Framing = Framing.XOR) -> Decoder:
        """Decoder for what a board sends: replies, error replies and events (and filler,
        dropped unless ``drop_filler=False``: then every byte is a frame's or garbage)."""
        return cls(
            _layouts(REPLY_TYPES, EVENT_TYPES),
            accept_errors=True,
            drop_filler=drop_filler,
            framing=framing,
        )

    @classmethod
    def from_host(cls, *, keep_invalid: bool = False, framing: Framing = Framing.XOR) -> Decoder:
        """Decoder for what a host sends: requests (see :class:`InvalidValues`)."""
        return cls(
            _layouts(REQUEST_TYPES), accept_errors=False, keep_invalid=keep_invalid, framing=framing
        )

    @property
    def framing(self) -> Framing:
        """How this decoder checks frames."""
        return Framing.CRC16 if self._crc else Framing.XOR

    @property
    def buffered(self) -> int:
        """Bytes held back because they may be the start of a frame."""
        return len(self._buffer)

    def peek(self) -> bytes:
        """The bytes held back (not consumed: see :attr:`buffered`)."""
        return bytes(self._buffer)

    def reset(self) -> bytes:
        """Forget buffered bytes (after a resync); returns what was dropped."""
        dropped = bytes(self._pending_garbage + self._buffer)
        self._buffer.clear()
        self._pending_garbage.clear()
        self._aligned = True
        return dropped

    def whole_frame(self, data: bytes | bytearray | memoryview) -> Frame | None:
        """``data`` as one frame when it is exactly one valid fixed-size frame and no
        earlier bytes are buffered (a reply arriving alone); otherwise None, and nothing
        was consumed: pass ``data`` to :meth:`feed`.  Same result as ``feed`` would give.
        """
        if self._buffer or type(data) is not bytes:
            return None
        memo = self._memo
        frame = memo.get(data)
        if frame is not None:
            self._aligned = True
            return frame
        if len(data) < 3 or data[0] & ERROR_FLAG:
            return None
        layout = self._layouts.get((data[0] << 8) | data[1])
        if (
            layout is None
            or layout.length_offset >= 0
            or layout.base_size + self._extra != len(data)
        ):
            return None
        if self._crc:
            if binascii.crc_hqx(data, CRC16_INIT):
                return None
        else:
            check = 0
            for byte in data:
                check ^= byte
            if check:
                return None
        try:
            frame = layout.decode(data)
        except ValueError:
            return None
        if len(memo) >= self.MEMO_SIZE:
            memo.clear()
        memo[data] = frame
        self._aligned = True
        return frame

    def feed(self, data: bytes | bytearray | memoryview) -> list[Decoded]:
        """Add received bytes; return every frame (and garbage run) now complete."""
        whole = self.whole_frame(data)
        if whole is not None:
            return [whole]
        buffer = self._buffer
        buffer += data
        out: list[Decoded] = []
        pos = 0
        end = len(buffer)
        while pos < end:
            size = self._candidate_size(buffer, pos, end)
            if size == 0:
                break  # need more bytes
            if size > 0 and pos + size > end:
                break
            if size > 0:
                frame = self._decode(buffer, pos, size)
                if frame is not None:
                    if self._pending_garbage:
                        out.append(Garbage(bytes(self._pending_garbage)))
                        self._pending_garbage.clear()
                    out.append(frame)
                    pos += size
                    self._aligned = True
                    continue
            elif buffer[pos] == FILLER and self._aligned and self._drop_filler:
                # no frame starts here: skip the whole run of filler at C speed
                pos = end - len(buffer[pos:end].lstrip(_FILLER_BYTE))
                continue
            self._pending_garbage.append(buffer[pos])
            self._aligned = False
            pos += 1
        del buffer[:pos]
        if self._pending_garbage:
            # Report garbage as soon as it is known, so a caller can start resyncing.
            out.append(Garbage(bytes(self._pending_garbage)))
            self._pending_garbage.clear()
        return out

    def _candidate_size(self, buffer: bytearray, pos: int, end: int) -> int:
        """Length of the frame that may start at ``pos``: 0 = need more, -1 = none."""
        first = buffer[pos]
        if first & ERROR_FLAG:
            return self._error_size if self._accept_errors else -1
        if pos + 1 >= end:
            # A lone first byte: wait only if some frame can start with it.
            return 0 if first in self._first_bytes else -1
        layout = self._layouts.get((first << 8) | buffer[pos + 1])
        if layout is None:
            return -1
        if layout.length_offset < 0:
            return layout.base_size + self._extra
        if pos + layout.length_offset >= end:
            return 0
        size = layout.base_size + buffer[pos + layout.length_offset]
        return size + self._extra if size <= layout.max_size else -1

    def _decode(self, buffer: bytearray, pos: int, size: int) -> Frame | InvalidValues | None:
        raw = bytes(buffer[pos : pos + size])
        memo = self._memo
        frame: Frame | None = memo.get(raw)
        if frame is not None:
            return frame
        if self._crc:
            if binascii.crc_hqx(raw, CRC16_INIT):
                return None
        else:
            check = 0
            for byte in raw:
                check ^= byte
            if check:
                return None
        try:
            first = raw[0]
            if first & ERROR_FLAG:  # rare: not remembered
                return ErrorReply(first & ~ERROR_FLAG, raw[1], ErrorCode(raw[2]))
            frame = self._layouts[(first << 8) | raw[1]].decode(raw)
        except ValueError:
            return InvalidValues(raw) if self._keep_invalid else None
        if len(memo) >= self.MEMO_SIZE:
            memo.clear()
        memo[raw] = frame
        return frame
