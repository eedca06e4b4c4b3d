"""Which USB bridge a serial port sits behind, read from its USB IDs.

The Uno's stock bridge, an ATmega16U2 (an 8U2 on the first Unos) running Arduino's
``arduino-usbserial``, passes board-to-host bytes on only when its Timer0 overflows (every
4.096 ms) or when more than 96 bytes wait, so every reply waits 2 ms on average.  The
board's low-latency mode pads replies past that threshold; it is worth its link time only
behind such a bridge (docs/concepts/baud-rate.md).  Other bridges -- CH340, CP210x, FTDI
with its latency timer at 1 ms -- pass bytes on without a tick, and a pseudo-terminal or a
network URL has no USB IDs at all: for those the answer is None.
"""

from __future__ import annotations

import logging
import os
from typing import Final

from serial.tools import list_ports

from ._bridges import BRIDGES

__all__ = ["TICK_HOLDING_BRIDGES", "tick_holding_bridge"]

logger = logging.getLogger(__name__)

#: (USB vendor ID, product ID) of the boards whose bridge runs arduino-usbserial on an
#: ATmega8U2/16U2 and so holds replies for its tick (the Unos and Megas this firmware runs
#: on), with the bridge's name: the tick-holding entries of ``transport._bridges.BRIDGES``.
TICK_HOLDING_BRIDGES: Final[dict[tuple[int, int], str]] = {
    (vid, pid): bridge.name
    for bridge in BRIDGES
    if bridge.tick_holding
    for vid, pid in bridge.ids
    if pid is not None
}


def tick_holding_bridge(port: str) -> str | None:
    """The name of the tick-holding bridge ``port`` is on, or None when it is another
    bridge or unknown.  Blocking (it reads sysfs): run it in a worker thread."""
    try:
        target = os.path.realpath(port)
    except (OSError, ValueError):
        return None
    for info in list_ports.comports():
        if os.path.realpath(info.device) != target or info.vid is None or info.pid is None:
            continue
        name = TICK_HOLDING_BRIDGES.get((info.vid, info.pid))
        logger.debug("%s: USB %04X:%04X (%s)", port, info.vid, info.pid, name or "no tick")
        return name
    return None
