"""One opener for every kind of board address: :func:`open_board`.

The address says where the board is, and this module is the one place that reads it:

* ``zenoh://0x0007[@endpoint]``: a board another computer serves
  (:func:`arduinoio_async.network.open_remote_board`, the optional network package);
* anything else: a local port -- a device path (``/dev/ttyACM0``), a virtual Uno's
  pseudo-terminal, or a pyserial URL (``socket://``, ``rfc2217://``) -- opened by
  :meth:`Board.open <arduinoio_async.board.Board.open>`.

It sits above both the board and the network layers, so neither imports the other.
``Board.open("zenoh://...")`` keeps working: the package's ``__init__`` registers this
module for the network's scheme (:mod:`arduinoio_async._schemes`) and ``Board.open``
hands such an address here.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from . import protocol as p
from ._schemes import scheme_of
from .board import READY_TIMEOUT, Board
from .errors import UsageError
from .transport import DEFAULT_TIMEOUT

__all__ = ["REMOTE_SCHEMES", "open_board"]

#: The schemes of boards served on the network.
REMOTE_SCHEMES = ("zenoh",)


@asynccontextmanager
async def open_board(
    address: str,
    *,
    baudrate: int = p.DEFAULT_BAUD,
    timeout: float = DEFAULT_TIMEOUT,
    ready_timeout: float = READY_TIMEOUT,
    **serial_options: Any,
) -> AsyncIterator[Board]:
    """The board at ``address``, open while the block runs.

    ``timeout`` is the default per-request timeout, ``ready_timeout`` bounds the wait for
    the board to answer; ``baudrate`` and the other keyword options (``trace``,
    ``low_latency``) are :meth:`Board.open`'s and apply to a local port only (a served
    board's server chose them).
    """
    scheme = scheme_of(address)
    if scheme in REMOTE_SCHEMES:
        if serial_options or baudrate != p.DEFAULT_BAUD:
            given = sorted([*serial_options, *(["baudrate"] if baudrate != p.DEFAULT_BAUD else [])])
            raise UsageError(
                f"{', '.join(given)}: options of a local port; the server of {address} chose them"
            )
        from .network import open_remote_board  # the optional package, on first use

        async with open_remote_board(address, timeout=timeout, ready_timeout=ready_timeout) as b:
            yield b
        return
    async with Board.open(
        address, baudrate=baudrate, timeout=timeout, ready_timeout=ready_timeout, **serial_options
    ) as board:
        yield board
