"""What a link session hands out: exchanges, outcomes, counters, states, board errors.

Split from :mod:`arduinoio_async.protocol.session` so that module holds only the rules.
"""

from __future__ import annotations

import math
from typing import Any

from ..errors import (
    ArduinoIOError,
    BoardError,
    FailsafeTrippedError,
    I2CError,
    LinkCapacityError,
)
from ._constants import ErrorCode
from ._messages import ErrorReply, Event, Reply, Request

__all__ = ["Exchange", "LinkStats", "Received", "SessionState", "board_error"]

_ERROR_CLASSES: dict[ErrorCode, type[BoardError]] = {
    ErrorCode.I2C_NACK_ADDRESS: I2CError,
    ErrorCode.I2C_NACK_DATA: I2CError,
    ErrorCode.I2C_TIMEOUT: I2CError,
    ErrorCode.I2C_STREAMING: I2CError,
    ErrorCode.I2C_NOT_CONFIGURED: I2CError,
    ErrorCode.LINK_CAPACITY: LinkCapacityError,
    ErrorCode.FAILSAFE_TRIPPED: FailsafeTrippedError,
}


def board_error(reply: ErrorReply, request: Request[Any]) -> BoardError:
    """The exception for an error reply to ``request``."""
    return _ERROR_CLASSES.get(reply.code, BoardError)(reply.code, request)


class SessionState:
    """Where the session is; plain strings keep the hot path cheap."""

    READY = "ready"
    #: Sync lost: the shell drains the line (feeding what it reads), then probes.
    DRAINING = "draining"
    #: An ID request is on its way; the queue waits for its answer.
    PROBING = "probing"
    CLOSED = "closed"


class LinkStats:
    """Counters for diagnostics and benchmarks."""

    __slots__ = (
        "ambiguous",
        "dropped_late_replies",
        "events",
        "framing_switches",
        "garbage_bytes",
        "lost_replies",
        "probes",
        "replies",
        "requests",
        "resyncs",
        "retries",
        "timeouts",
    )

    def __init__(self) -> None:
        self.requests = 0
        self.replies = 0
        self.events = 0
        self.timeouts = 0
        #: Times the link regained sync (on the reply stream or by a probe).
        self.resyncs = 0
        #: Of those, the ones that needed a drain and an ID probe.
        self.probes = 0
        self.garbage_bytes = 0
        self.dropped_late_replies = 0
        #: Requests whose reply line noise destroyed.
        self.lost_replies = 0
        #: Re-sends of idempotent requests.
        self.retries = 0
        #: Frames after noise that could answer more than one request (counted as noise).
        self.ambiguous = 0
        #: Framing changes: SetFraming confirmed, or a probe found the other framing.
        self.framing_switches = 0

    def as_dict(self) -> dict[str, int]:
        return {name: getattr(self, name) for name in self.__slots__}


class Exchange:
    """One request's life: queued, in flight, done (with ``reply`` or ``error``).

    ``waiter`` and ``deadline`` belong to the shell (what its caller waits on, and until
    when); the session never looks at them.
    """

    __slots__ = (
        "abandoned",
        "attempts",
        "crc",
        "deadline",
        "done",
        "error",
        "frame",
        "internal",
        "queued",
        "reply",
        "request",
        "size",
        "waiter",
    )

    def __init__(
        self, request: Request[Any], frame: bytes, internal: bool = False, crc: bool = False
    ) -> None:
        self.request = request
        self.frame = frame
        self.size = len(frame)
        #: ``frame`` ends in a CRC-16 (negotiated framing), not in the XOR byte.
        self.crc = crc
        self.queued = True
        self.done = False
        self.abandoned = False
        self.internal = internal
        self.attempts = 0
        self.reply: Reply | None = None
        self.error: ArduinoIOError | None = None
        self.waiter: Any = None
        self.deadline = math.inf

    def __repr__(self) -> str:
        state = "done" if self.done else "queued" if self.queued else "in flight"
        return f"<Exchange {self.request!r} {state}>"


class Received:
    """What one call into the session produced."""

    __slots__ = ("done", "events", "hold", "lost", "outgoing")

    def __init__(self) -> None:
        #: Exchanges that finished (in FIFO order); each appears once in a session's life.
        self.done: list[Exchange] = []
        self.events: list[Event] = []
        #: Bytes to write now (admitted requests, a marker or a probe).
        self.outgoing = b""
        #: Why sync was lost during the call, or None.
        self.lost: str | None = None
        #: A CRC-framed reply that ended the read is held: call the session's
        #: ``release_held`` once the line stayed quiet for one byte time (see there).
        self.hold = False
