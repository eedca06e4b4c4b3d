"""What a served board needs from the server that serves it, typed by a small Protocol.

:class:`~._served_board.ServedBoard` and its failsafe-owner watch are children of
:class:`~._server.BoardServer`: they are handed the server as a :class:`ServingHost`
and know nothing else of it, so the import graph points from the server down to them
and never back up.
"""

from __future__ import annotations

from collections.abc import Callable, Set
from typing import Any, Protocol

import zenoh

from ._loop import LoopHandle

__all__ = ["ServingHost"]


class ServingHost(Protocol):
    """The serving side of a board: its Zenoh session, its loop, its task group, its clients."""

    @property
    def session(self) -> zenoh.Session:
        """The Zenoh session the board's entities are declared on."""
        ...

    @property
    def loop(self) -> LoopHandle:
        """The event loop, for Zenoh's callbacks to schedule work in."""
        ...

    @property
    def live_clients(self) -> Set[str]:
        """Clients whose liveliness token is up (changed in place by the server)."""
        ...

    def start_soon(self, func: Callable[..., Any], *args: Any) -> None:
        """Start ``func(*args)`` in the server's task group, from any code in the loop."""
        ...
