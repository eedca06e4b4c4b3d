"""Meeting a board's boot: waiting until it answers, and telling one boot from the next.

Why a module of its own: an Uno resets when its port opens (DTR), on a watchdog reset and
on a brown-out, and every path that meets a fresh boot -- opening a port, ``Board.reset``,
the manager's reconnect, writing the board ID -- waits for the firmware the same way:
polling with short timeouts within one deadline (a real Uno answers 1.6-2 s after the
open; a fixed sleep would cost every user that long), a checkpoint in every retry, and
never a busy loop on a link that is gone (a closed link fails at once, every time).
Boots are told apart by the session tag the library writes into the board
(``SetSession``): a fresh boot reports 0.
"""

from __future__ import annotations

import anyio
import anyio.abc
import anyio.lowlevel

from .. import protocol as p
from ..errors import BoardDisconnectedError, BoardIdChangedError, BoardTimeoutError, LinkError
from ..transport import DEFAULT_TIMEOUT, TraceHook, Transport
from ..transport._ready import wait_ready

__all__ = ["READY_TIMEOUT", "check_same_board", "read_id_retrying", "start_link", "wait_new_boot"]

#: How long ``Board.open`` waits for a board to answer: a real Uno resets when its port
#: opens and answers 1.6-2 s later.
READY_TIMEOUT = 5.0


async def start_link(
    stream: anyio.abc.ByteStream,
    *,
    timeout: float = DEFAULT_TIMEOUT,
    ready_timeout: float = READY_TIMEOUT,
    trace: TraceHook | None = None,
    name: str = "",
) -> Transport:
    """Wait for the board on ``stream`` and wrap it in a (not yet started) transport.

    The stream is closed if the board never answers or the wait is cancelled: the caller
    only owns it again once it is inside a transport.
    """
    name = name or getattr(stream, "port", "") or "board"
    try:
        await wait_ready(stream, deadline=anyio.current_time() + ready_timeout, name=name)
    except (anyio.BrokenResourceError, anyio.ClosedResourceError, anyio.EndOfStream) as exc:
        with anyio.CancelScope(shield=True):
            await stream.aclose()
        raise BoardDisconnectedError(f"{name}: port lost while waiting for the board") from exc
    except BaseException:
        with anyio.CancelScope(shield=True):
            await stream.aclose()
        raise
    return Transport(stream, timeout=timeout, trace=trace, name=name)


async def read_id_retrying(link: Transport, deadline: float) -> int:
    """The board's ID, asked until it answers within ``deadline`` seconds
    (BoardTimeoutError: only the library's own exceptions leave it)."""
    with anyio.move_on_after(deadline):
        while True:
            try:
                return (await link.request(p.ReadId())).board_id
            except BoardDisconnectedError:
                raise
            except LinkError:
                await anyio.lowlevel.checkpoint()
    raise BoardTimeoutError(f"{link.name}: no answer to ReadId within {deadline:g} s")


async def wait_new_boot(link: Transport, session: int, *, deadline: float, who: str) -> None:
    """Poll until the board on ``link`` reports a session tag other than ``session``: it
    has booted since it was tagged.  BoardTimeoutError names ``who`` after ``deadline``
    seconds."""
    try:
        with anyio.fail_after(deadline):
            while True:
                try:
                    status = await link.request(p.ReadStatus(), timeout=0.1)
                except BoardDisconnectedError:
                    raise  # a closed link never answers: no busy loop
                except LinkError:
                    await anyio.lowlevel.checkpoint()
                    continue
                if status.session != session:
                    return
    except TimeoutError as exc:
        if isinstance(exc, BoardTimeoutError):
            raise
        raise BoardTimeoutError(
            f"{who} did not come back from its reboot within {deadline:g} s"
        ) from None


async def check_same_board(link: Transport, board_id: int) -> None:
    """Raise BoardIdChangedError unless the fresh boot on ``link`` is board ``board_id``.

    An ID can change in place (a raw ``WriteId``, then a reset), so a fresh boot is asked
    for its ID with any ID accepted; a different answer is asked again before it counts
    (the 8-bit checksum lets about one damaged frame in 256 through).
    """
    link.expected_id = None
    found = (await link.request(p.ReadId())).board_id
    if found != board_id and (await link.request(p.ReadId())).board_id == found:
        raise BoardIdChangedError(link.name, board_id, found)
