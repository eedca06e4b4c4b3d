"""One I/O board: :class:`Board`, its pin-role table, its failsafe and keepalive.

* :mod:`.board`: :class:`Board` itself (opening, requests, the typed-handle factories);
* :mod:`.roles`: :class:`PinRoles`, the public record of which pin holds which role,
  which the handles use and the board replays after a reset;
* :mod:`.failsafe`: the failsafe and the keepalive heartbeat that feeds it.

The handles themselves are in :mod:`arduinoio_async.board.handles`.
"""

from __future__ import annotations

from .board import READY_TIMEOUT, Board
from .failsafe import HEARTBEATS_PER_TIMEOUT, IDLE_HEARTBEAT, FailsafeConfig
from .roles import Claim, PinRoles

__all__ = [
    "HEARTBEATS_PER_TIMEOUT",
    "IDLE_HEARTBEAT",
    "READY_TIMEOUT",
    "Board",
    "Claim",
    "FailsafeConfig",
    "PinRoles",
]
