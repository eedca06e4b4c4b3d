"""Which layer opens an address with a URL scheme the board layer does not know.

:meth:`Board.open <arduinoio_async.board.Board.open>` opens device paths and pyserial
URLs itself; an address such as ``zenoh://0x0007`` belongs to a layer *above* the board
(the network), which the board must not import.  The package's ``__init__`` (the
composition root, above every layer) registers here, by scheme, a function that imports
the one opener (:mod:`arduinoio_async.opener`) on first use; ``Board.open`` looks the
scheme up and hands the address over.  This module imports nothing of the package, so
every layer may use it.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractAsyncContextManager
from typing import Any

__all__ = ["SchemeOpener", "opener_for", "register", "scheme_of"]

#: ``opener(address, timeout=..., ready_timeout=...)``: an async context manager that
#: yields the open board.
SchemeOpener = Callable[..., AbstractAsyncContextManager[Any]]

_OPENERS: dict[str, SchemeOpener] = {}


def scheme_of(address: str) -> str:
    """``"zenoh"`` for ``zenoh://0x0007``; ``""`` for an address without ``://``."""
    scheme, sep, _rest = address.partition("://")
    return scheme.lower() if sep else ""


def register(scheme: str, opener: SchemeOpener) -> None:
    """Open addresses of ``scheme`` with ``opener`` (a later registration replaces it)."""
    _OPENERS[scheme.lower()] = opener


def opener_for(address: str) -> SchemeOpener | None:
    """The registered opener of ``address``'s scheme, or None (a serial address)."""
    return _OPENERS.get(scheme_of(address))
