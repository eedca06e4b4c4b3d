"""Waiting for a board that may still be booting.

A real Uno resets when its port is opened (DTR auto-reset): the bootloader listens for
about half a second and the firmware answers some 1.6-2 s after the open.  Sleeping a
fixed 4-5 s (what Firmata and Telemetrix clients do) is slow and still not safe.  Instead
the host sends the paper's ID request every ``poll_interval`` and stops at the first valid
reply, then drains the replies of earlier polls that may still be on their way, so the
transport starts on a clean line.

The drain ends when every poll has had its reply, or when no *reply* has come for
``settle`` (a poll the booting board never heard gets none).  Board-initiated frames
(class 0x40) are no replies: they neither end nor prolong the wait.  On a board served
on the network another client's stream sends them without pause (every 20 ms for the
monitor), so waiting for a quiet line would never end there; on a serial line a stream
a previous program left running would do the same.

A board that did not reset on the open may still be in the CRC-16 framing an earlier
program negotiated (docs/protocol.md 7.7): it answers the XOR-framed poll with a CRC-framed
error.  What arrives is decoded in both framings; a CRC-framed answer to the poll makes
the next poll a CRC-framed ``SetFraming(XOR)``, so the transport always starts in the
framing of a fresh boot and negotiates from there.
"""

from __future__ import annotations

import anyio
import anyio.abc

from .. import protocol as p
from ..errors import BoardDisconnectedError, BoardSilentError
from ._streams import LinkAttribute

__all__ = ["wait_ready"]

POLL_INTERVAL = 0.1
SETTLE_TIME = 0.03


async def wait_ready(
    stream: anyio.abc.ByteStream,
    *,
    deadline: float,
    poll_interval: float = POLL_INTERVAL,
    settle: float = SETTLE_TIME,
    name: str = "board",
) -> int:
    """Poll with ID requests until the board answers; return its ID.

    Raises :class:`BoardSilentError` naming what arrived instead when ``deadline``
    (an ``anyio.current_time()`` value) passes, and :class:`BoardDisconnectedError` when
    the port goes away meanwhile.
    """
    try:
        return await _wait_ready(stream, deadline, poll_interval, settle, name)
    except (anyio.BrokenResourceError, anyio.ClosedResourceError, anyio.EndOfStream) as exc:
        raise BoardDisconnectedError(f"{name}: port lost while waiting for the board") from exc


async def _wait_ready(
    stream: anyio.abc.ByteStream, deadline: float, poll_interval: float, settle: float, name: str
) -> int:
    decoder = p.Decoder.from_board()
    crc_decoder = p.Decoder.from_board(framing=p.Framing.CRC16)
    request = p.ReadId().encode()
    back_to_xor = p.crc_framed(p.SetFraming(p.Framing.XOR).encode())
    in_crc = False
    heard = bytearray()
    board_id: int | None = None
    polls = replies = 0
    while board_id is None:
        if anyio.current_time() >= deadline:
            raise BoardSilentError(
                name, bytes(heard), baudrate=stream.extra(LinkAttribute.baudrate, None)
            )
        if in_crc:
            await stream.send(back_to_xor)
        else:
            await stream.send(request)
            polls += 1
        in_crc = False
        poll_end = min(deadline, anyio.current_time() + poll_interval)
        with anyio.move_on_after(max(0.0, poll_end - anyio.current_time())):
            while board_id is None:  # (the poll's time: a board that reported a
                # framing error discards what comes within 10 ms)
                data = await stream.receive()
                heard += data[: max(0, 64 - len(heard))]
                for item in decoder.feed(data):
                    if isinstance(item, p.ReadIdReply):
                        replies += 1
                        board_id = item.board_id
                if any(_answers_poll(item) for item in crc_decoder.feed(data)):
                    in_crc = True
    # Replies to earlier polls may still arrive: drain them before handing over.
    quiet_until = anyio.current_time() + settle
    limit = max(deadline, quiet_until)  # a line that never stops babbling ends too
    while (replies < polls or decoder.buffered) and anyio.current_time() < quiet_until:
        with anyio.move_on_after(quiet_until - anyio.current_time()):
            data = await stream.receive()
            for item in decoder.feed(data):
                if isinstance(item, p.Event):
                    continue  # not an answer to a poll (see the module docstring)
                if isinstance(item, p.ReadIdReply):
                    replies += 1
                quiet_until = min(limit, anyio.current_time() + settle)
    return board_id


def _answers_poll(item: p.Decoded) -> bool:
    """A CRC-framed answer to the ID poll: the board is in CRC-16 framing."""
    if isinstance(item, p.ReadIdReply):
        return True
    return (
        isinstance(item, p.ErrorReply)
        and item.framing
        and item.class_tag == p.ClassTag.MISC
        and item.descriptor in (0, p.ReadId.LAYOUT.descriptor)
    )
