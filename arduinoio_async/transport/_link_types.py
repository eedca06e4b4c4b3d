"""The transport's constants and public types: timeouts, the framing it asks for, the
link's state and the trace record (:mod:`._link` is the engine that uses them)."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Literal

from .. import protocol as p
from ..errors import UsageError
from ..protocol.session import SessionState
from ._usb import tick_holding_bridge

__all__ = [
    "ARMED_QUIET_TIME",
    "DEFAULT_TIMEOUT",
    "FRAMING_ENV",
    "MAX_DRAIN",
    "MAX_PROBE_BACKOFF",
    "QUIET_TIME",
    "LinkState",
    "TraceHook",
    "TraceRecord",
    "default_framing",
]

#: Default time a request may take, queueing and retries included.  Generous against a
#: real Uno whose USB bridge adds up to 4 ms per reply and whose I2C or EEPROM commands
#: take milliseconds.
DEFAULT_TIMEOUT = 0.5
#: Silence that proves the line is drained: the board's 10 ms inter-byte gap, plus a 4 ms
#: USB-bridge tick and a USB frame, with margin.
QUIET_TIME = 0.03
#: The drain's quiet time while a failsafe is armed (``max_silence`` set): twice the
#: board's 10 ms inter-byte gap, so a resync's first probe goes out sooner and a lost
#: probe plus a corrupted poll cannot keep the board unfed for a whole 100 ms failsafe
#: (tests/e2e/test_failsafe_resync_silence.py).
ARMED_QUIET_TIME = 0.02
#: Longest drain before probing anyway.
MAX_DRAIN = 0.25
#: Longest pause between probes that got no answer.
MAX_PROBE_BACKOFF = 1.0
#: Environment variable that picks the framing a link asks for when ``framing`` is not
#: given: ``xor`` (the paper's) or ``crc16``; unset, the link decides (``default_framing``).
FRAMING_ENV = "ARDUINOIO_FRAMING"


def default_framing(port: str = "") -> p.Framing:
    """The framing a link asks for by default: ``ARDUINOIO_FRAMING`` if set, else CRC-16
    behind a bridge that holds replies for a timer tick (an Uno's or a Mega's 16U2, known
    by ``port``'s USB IDs), else the paper's XOR.  Blocking when ``port`` is given (it
    reads sysfs): run it in a worker thread.

    The two check bytes CRC-16 adds cost their byte times on the wire: at 1,000,000 baud
    that is more than the 5 % the project allows a default on a direct line (20 us of a
    185 us round trip), but about 1 % behind the 16U2, whose 4.096 ms tick and USB frames
    dominate every round trip (docs/protocol.md 7.7 has the arithmetic and the measured
    cost).  A board without the feature keeps XOR framing whatever is asked.
    """
    value = os.environ.get(FRAMING_ENV)
    if value is None:
        if port and tick_holding_bridge(port) is not None:
            return p.Framing.CRC16
        return p.Framing.XOR
    value = value.strip().lower()
    try:
        return p.Framing[value.upper()]
    except KeyError:
        raise UsageError(f"{FRAMING_ENV}={value!r}: use crc16 or xor") from None


class LinkState(Enum):
    READY = "ready"
    RESYNCING = "resyncing"
    CLOSED = "closed"


PUBLIC_STATE = {
    SessionState.READY: LinkState.READY,
    SessionState.DRAINING: LinkState.RESYNCING,
    SessionState.PROBING: LinkState.RESYNCING,
    SessionState.CLOSED: LinkState.CLOSED,
}


@dataclass(frozen=True, slots=True)
class TraceRecord:
    """One frame (or garbage run) crossing the link; ``time_ns`` is ``perf_counter_ns``."""

    time_ns: int
    direction: Literal["tx", "rx"]
    item: p.Frame | p.Garbage


TraceHook = Callable[[TraceRecord], None]
