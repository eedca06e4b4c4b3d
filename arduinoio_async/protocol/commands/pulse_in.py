"""PULSE_IN commands (class tag 0x0C, extension) and events, handled by ``firmware/src/pulse_in.c``.

Pulse-width inputs on any digital pin: the board stamps both edges of every high pulse in
its pin-change interrupt (the shared edge-timing layer, ``firmware/src/pulse.h``) with the
microsecond clock, so a width is the board's measurement, not a host round trip's.  The
use is an RC receiver's channel: 1,000-2,000 us high pulses about every 20 ms.  An input
lives in one of ``PULSE_IN_SLOTS`` slots the host picks.

Signal loss: when no pulse has ended for ``timeout_ms``, the slot is *lost* (its reads say
so, never an old width as if fresh) and the board sends a :class:`PulseInSignal` event;
another when pulses come back.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U8, U16
from .._messages import Event, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "PulseInConfig",
    "PulseInConfigReply",
    "PulseInRead",
    "PulseInReadReply",
    "PulseInSignal",
]


@echo
class _Slot:
    slot: Annotated[int, U8]


@echo
class _Config(_Slot):
    pin: Annotated[int, U8]
    #: Milliseconds without a pulse after which the signal is lost (1-65535).
    timeout_ms: Annotated[int, U16]


@reply_frame(ClassTag.PULSE_IN, 0x01)
class PulseInConfigReply(_Config, Reply): ...


# Not idempotent: a new configuration forgets the last width.
@request_frame(PulseInConfigReply, extension=True)
class PulseInConfig(_Config, Request[PulseInConfigReply]):
    """Time the high pulses on ``pin`` in ``slot``; lost after ``timeout_ms`` without one.

    A slot in use is reconfigured; its old pin is released.  The slot starts lost (no
    pulse yet), so the first pulse sends a PulseInSignal "back" event.
    """


@echo
class _State(_Slot):
    """A pulse input's state: its last width, how old it is, and whether the signal is lost."""

    #: The last complete high pulse in microseconds (0: none since CONFIG).
    width_us: Annotated[int, U16]
    #: Milliseconds since that pulse ended (65535 at most; 65535 before the first).
    age_ms: Annotated[int, U16]
    #: 1 when no pulse ended for the configured timeout, else 0.
    lost: Annotated[int, U8]


@reply_frame(ClassTag.PULSE_IN, 0x02)
class PulseInReadReply(_State, Reply): ...


@request_frame(PulseInReadReply, extension=True, reads_only=True)
class PulseInRead(_Slot, Request[PulseInReadReply]):
    """Read a pulse input's last width, its age and the signal state."""


@event_frame(0x09)
class PulseInSignal(_State, Event):
    """A pulse input's signal was lost (``lost`` 1: no pulse for the timeout) or came back
    (``lost`` 0: the first pulse after a loss or after CONFIG, whose width it carries).

    Sent by the board's main loop; one per change, never repeated while the state holds.
    """
