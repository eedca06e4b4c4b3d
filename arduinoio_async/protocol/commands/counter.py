"""COUNTER commands (class tag 0x06) and count reports, handled by ``firmware/src/counter.c``.

Edge counters on D2 (INT0) and D3 (INT1), 32 bit and wrapping, and the CounterReport
events a watched counter sends every ``every`` counts (docs/protocol.md 7.4).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag, Edge
from .._layout import U8, U16, U32
from .._messages import Event, OnePin, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "CounterConfig",
    "CounterConfigReply",
    "CounterRead",
    "CounterReadReply",
    "CounterReport",
    "CounterReset",
    "CounterResetReply",
    "CounterWatch",
    "CounterWatchReply",
]


@echo
class _Config(OnePin):
    edge: Annotated[Edge, U8]


@reply_frame(ClassTag.COUNTER, 0x01)
class CounterConfigReply(_Config, Reply): ...


# Not idempotent: a new configuration restarts the count.
@request_frame(CounterConfigReply)
class CounterConfig(_Config, Request[CounterConfigReply]):
    """Count edges on D2 (INT0) or D3 (INT1); the count starts at zero."""


@echo
class _Count(OnePin):
    count: Annotated[int, U32]


@reply_frame(ClassTag.COUNTER, 0x02)
class CounterReadReply(_Count, Reply): ...


@request_frame(CounterReadReply, reads_only=True)
class CounterRead(OnePin, Request[CounterReadReply]):
    """Read a counter (32 bit, wrapping)."""


@reply_frame(ClassTag.COUNTER, 0x03)
class CounterResetReply(_Count, Reply): ...


# Not idempotent: it clears the count.
@request_frame(CounterResetReply, extension=True)
class CounterReset(OnePin, Request[CounterResetReply]):
    """Read and clear a counter in one step, so no event falls between the two."""


@echo
class _Watch(OnePin):
    every: Annotated[int, U16]


@reply_frame(ClassTag.COUNTER, 0x04)
class CounterWatchReply(_Watch, Reply): ...


@request_frame(CounterWatchReply, extension=True, idempotent=True)
class CounterWatch(_Watch, Request[CounterWatchReply]):
    """Send a CounterReport every ``every`` counts (0 stops); ends with a new CONFIG."""


@event_frame(0x04)
class CounterReport(_Count, Event):
    """A watched counter reached another ``every`` counts (docs/protocol.md 7.4).

    ``count`` is the count when the interrupt ran; a report the transmit buffer had no
    room for is dropped, which the next report's count shows.
    """

    timestamp_us: Annotated[int, U32]
