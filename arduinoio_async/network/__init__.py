"""Boards anywhere on the robot's network, over Zenoh (``pip install arduinoio_async[network]``).

``arduinoio serve`` (:class:`BoardServer`) owns the local boards and serves each under
its board ID; :func:`open_remote_board` (or ``Board.open("zenoh://0x0007")``) gives the
same :class:`~arduinoio_async.board.Board` API for a board served on another machine, and
:class:`NetworkBoardManager` finds boards by ID on local ports and on the network alike.
Requests travel as Zenoh queries carrying the protocol's own frames, so the sans-IO
core's echo checks and error mapping hold end to end.  See ``docs/network.md``.
"""

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
