"""Waiting for a board that may still be booting.

A real Uno resets when its port is opened (DTR auto-reset): the bootloader listens for
about half a second and the firmware answers some 1.6-2 s after the open.  Sleeping a
fixed 4-5 s (what Firmata and Telemetrix clients do) is slow and still not safe.  Instead
the host sends the paper's ID request every ``poll_interval`` and stops at the first valid
reply, then drains the replies of earlier polls that may still be on their way, so the
transport starts on a clean line.
"""

from __future__ import annotations

import anyio
import anyio.abc

from .. import protocol as p
from ..errors import BoardDisconnectedError, BoardSilentError

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
    request = p.ReadId().encode()
    heard = bytearray()
    board_id: int | None = None
    while board_id is None:
        if anyio.current_time() >= deadline:
            raise BoardSilentError(name, bytes(heard), baudrate=getattr(stream, "baudrate", None))
        await stream.send(request)
        poll_end = min(deadline, anyio.current_time() + poll_interval)
        with anyio.move_on_after(max(0.0, poll_end - anyio.current_time())):
            while board_id is None:
                data = await stream.receive()
                heard += data[: max(0, 64 - len(heard))]
                for item in decoder.feed(data):
                    if isinstance(item, p.ReadIdReply):
                        board_id = item.board_id
    # Replies to earlier polls may still arrive: let the line go quiet before handing over.
    while True:
        with anyio.move_on_after(settle):
            await stream.receive()
            continue
        return board_id
