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
from ..errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardIdChangedError,
    BoardSilentError,
    BoardTimeoutError,
    LinkError,
)
from ..transport import DEFAULT_TIMEOUT, LinkAttribute, TraceHook, Transport, open_serial_stream
from ..transport._link_types import default_framing
from ..transport._ready import wait_ready
from ..transport._streams import abilities_of

__all__ = [
    "READY_TIMEOUT",
    "check_same_board",
    "explain_silence",
    "look_at_bootloader",
    "read_id_retrying",
    "start_link",
    "wait_new_boot",
]

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
    port = stream.extra(LinkAttribute.port, "")
    name = name or port or "board"
    framing = None  # the transport's own default (a relaying stream keeps XOR)
    try:
        if port and not abilities_of(stream).relays:  # by the port's bridge: sysfs, blocking
            framing = await anyio.to_thread.run_sync(default_framing, port)
        await wait_ready(stream, deadline=anyio.current_time() + ready_timeout, name=name)
    except (anyio.BrokenResourceError, anyio.ClosedResourceError, anyio.EndOfStream) as exc:
        with anyio.CancelScope(shield=True):
            await stream.aclose()
        raise BoardDisconnectedError(f"{name}: port lost while waiting for the board") from exc
    except BaseException:
        with anyio.CancelScope(shield=True):
            await stream.aclose()
        raise
    return Transport(stream, timeout=timeout, trace=trace, name=name, framing=framing)


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
    seconds.

    The board is silent while it boots, so polls time out and the link resyncs: expected
    here, so the link logs it as such, not as a lost sync (a real loss stays a warning).
    """
    try:
        with link.expecting_reboot(), anyio.fail_after(deadline):
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


# ---- a board that stays silent -------------------------------------------------------------

#: The Uno's bootloader (optiboot) speaks STK500 at this rate, whatever the firmware's.
BOOTLOADER_BAUD = 115200
#: How long to look for the bootloader after the reset that opening the port causes: it
#: listens for about 1 s after the reset.
BOOTLOADER_WINDOW = 2.0
_STK_INSYNC, _STK_OK = 0x14, 0x10


async def _stk(stream: anyio.abc.ByteStream, command: bytes, answer: int, wait: float) -> bytes:
    """Send an STK500 ``command``; its ``answer`` bytes between INSYNC and OK (TimeoutError
    after ``wait`` seconds, ValueError on anything else)."""
    await stream.send(command)
    got = bytearray()
    with anyio.fail_after(wait):
        while len(got) < answer + 2:
            got += await stream.receive()
    if got[0] != _STK_INSYNC or got[answer + 1] != _STK_OK:
        raise ValueError(f"no STK500 answer: {bytes(got).hex(' ')}")
    return bytes(got[1 : answer + 1])


async def _drain(stream: anyio.abc.ByteStream, quiet: float = 0.2, limit: float = 1.0) -> None:
    """Read until nothing arrived for ``quiet`` seconds (at most ``limit``): late answers
    to repeated syncs would otherwise meet the next command, or the next program."""
    with anyio.move_on_after(limit):
        while True:
            with anyio.move_on_after(quiet):
                await stream.receive()
                continue
            return


async def _sync(stream: anyio.abc.ByteStream) -> None:
    """avrdude's first step: GET_SYNC until the bootloader answers, then a quiet line.

    Each try waits long enough for its answer (the bootloader answers at once; a busy
    host reads late), so few tries are outstanding when one is answered."""
    while True:
        try:
            await _stk(stream, b"\x30\x20", 0, 0.25)
            break
        except (TimeoutError, ValueError):
            await anyio.lowlevel.checkpoint()
    await _drain(stream)


async def look_at_bootloader(port: str) -> str | None:
    """What the bootloader of the board on ``port`` says: "empty" when no application is
    in its flash, "program" when one is, None when no STK500 bootloader answered.

    Opening the port resets an Uno into its bootloader (DTR, as for avrdude); this asks
    what avrdude asks first -- sync, then the flash's first word (0xFFFF: erased) -- and
    leaves the bootloader, which then starts whatever the flash holds.  The line is left
    quiet for whoever opens the port next (``arduinoio flash``).
    """
    try:
        stream = await open_serial_stream(port, BOOTLOADER_BAUD)
    except ArduinoIOError:
        return None
    found: str | None = None
    try:
        try:
            with anyio.move_on_after(BOOTLOADER_WINDOW):
                await _sync(stream)
                await _stk(stream, b"\x55\x00\x00\x20", 0, 0.25)  # LOAD_ADDRESS 0
                first = await _stk(stream, b"\x74\x00\x02\x46\x20", 2, 0.25)  # READ_PAGE
                await _stk(stream, b"\x51\x20", 0, 0.25)  # LEAVE_PROGMODE
                found = "empty" if first == b"\xff\xff" else "program"
        except (TimeoutError, ValueError):
            pass  # something answered, but not as a bootloader does
        await _drain(stream)
    except (anyio.BrokenResourceError, anyio.EndOfStream):
        return None
    finally:
        with anyio.CancelScope(shield=True):
            await stream.aclose()
    return found


async def explain_silence(port: str, baudrate: int, silent: BoardSilentError) -> BoardSilentError:
    """``silent`` again, with what the board's bootloader says (see BoardSilentError)."""
    found = await look_at_bootloader(port)
    return BoardSilentError(port, silent.heard, baudrate=baudrate, bootloader=found)
