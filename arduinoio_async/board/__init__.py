"""One I/O board: :class:`Board`, its handles, and what keeps them across resets.

The board layer sits on the transport and under the manager; inside it the modules import
in one direction (``tests/test_import_graph.py`` checks it):

* :mod:`.roles`: :class:`PinRoles`, the public record of which pin holds which role;
* :mod:`.watches`: the change, counter, analog and stream subscriptions, restored after a
  reset;
* :mod:`._core`: :class:`BoardCore`, what a handle may use of its board;
* the handles, typed against ``BoardCore`` (they never import :class:`Board`):
  :mod:`.handles` (pins), :mod:`.changes` (pushed input changes), :mod:`.streaming`
  (firmware-timed samples), :mod:`.transactions`, :mod:`.motors`;
* :mod:`.failsafe`: the failsafe and the keepalive heartbeat; :mod:`.boot`: waiting for
  a boot of the board;
* :mod:`.board`: :class:`Board` itself (opening, requests, restore), with the handle
  factories mixed in from :mod:`._pin_methods` and :mod:`._motor_methods`;
* :mod:`.model`: the board's model, read at open; :mod:`.mega`: :class:`Mega2560Board`,
  a ``Board`` typed with the Mega's pins.
"""

from __future__ import annotations

from ._core import BoardCore
from .board import READY_TIMEOUT, Board
from .failsafe import HEARTBEATS_PER_TIMEOUT, IDLE_HEARTBEAT, FailsafeConfig
from .mega import Mega2560Board, WrongBoardModelError
from .roles import Claim, PinRoles

__all__ = [
    "HEARTBEATS_PER_TIMEOUT",
    "IDLE_HEARTBEAT",
    "READY_TIMEOUT",
    "Board",
    "BoardCore",
    "Claim",
    "FailsafeConfig",
    "Mega2560Board",
    "PinRoles",
    "WrongBoardModelError",
]
