"""Boards anywhere on the robot's network, over Zenoh (``pip install arduinoio_async[network]``).

``arduinoio serve`` (:class:`BoardServer`) owns the local boards and serves each under
its board ID; :func:`open_remote_board` (or ``Board.open("zenoh://0x0007")``) gives the
same :class:`~arduinoio_async.board.Board` API for a board served on another machine, and
:class:`NetworkBoardManager` finds boards by ID on local ports and on the network alike.
Requests travel as Zenoh queries carrying the protocol's own frames, so the sans-IO
core's echo checks and error mapping hold end to end.  See ``docs/network.md``.

The names are imported on first use, so the rest of the library (and the CLI's
``--remote`` option) works without the optional ``eclipse-zenoh`` package installed.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ._client import NetworkBoardManager, RemoteBoards, open_remote_board, parse_board_url
    from ._keys import DEFAULT_ENDPOINT, RemoteFault, zenoh_config
    from ._server import BoardServer
    from ._stream import RemoteByteStream

__all__ = [
    "DEFAULT_ENDPOINT",
    "BoardServer",
    "NetworkBoardManager",
    "RemoteBoards",
    "RemoteByteStream",
    "RemoteFault",
    "open_remote_board",
    "parse_board_url",
    "zenoh_config",
]

_MODULES = {
    "DEFAULT_ENDPOINT": "._keys",
    "BoardServer": "._server",
    "NetworkBoardManager": "._client",
    "RemoteBoards": "._client",
    "RemoteByteStream": "._stream",
    "RemoteFault": "._keys",
    "open_remote_board": "._client",
    "parse_board_url": "._client",
    "zenoh_config": "._keys",
}


def __getattr__(name: str) -> Any:
    module = _MODULES.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    try:
        return getattr(importlib.import_module(module, __name__), name)
    except ModuleNotFoundError as exc:
        if exc.name != "zenoh":
            raise
        raise ImportError(
            "boards on the network need Zenoh: pip install 'arduinoio_async[network]'"
        ) from exc
