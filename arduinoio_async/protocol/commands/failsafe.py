"""FAILSAFE commands (class tag 0x08, extension) and the trip event, handled by
``firmware/src/failsafe.c``.

A link watchdog every valid request feeds: when the host falls silent for ``timeout_ms``
the board applies each pin's safe state and sends FailsafeTripped.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag, SafeKind
from .._layout import U8, U16
from .._messages import Event, OnePin, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "FailsafeArm",
    "FailsafeArmReply",
    "FailsafeDisarm",
    "FailsafeDisarmReply",
    "FailsafeSafeState",
    "FailsafeSafeStateReply",
    "FailsafeTripped",
]


@echo
class _Timeout:
    timeout_ms: Annotated[int, U16]


@reply_frame(ClassTag.FAILSAFE, 0x01)
class FailsafeArmReply(_Timeout, Reply): ...


# Not idempotent: a repeat could hide a trip in between.
@request_frame(FailsafeArmReply, extension=True)
class FailsafeArm(_Timeout, Request[FailsafeArmReply]):
    """Arm the link watchdog; clears a tripped state.  Every valid request feeds it."""


@echo
class _SafeState(OnePin):
    kind: Annotated[SafeKind, U8]
    value: Annotated[int, U16]


@reply_frame(ClassTag.FAILSAFE, 0x02)
class FailsafeSafeStateReply(_SafeState, Reply): ...


@request_frame(FailsafeSafeStateReply, extension=True, idempotent=True)
class FailsafeSafeState(_SafeState, Request[FailsafeSafeStateReply]):
    """What a pin does when the watchdog fires: a level (0/1) or a pulse width (0 = none)."""


@reply_frame(ClassTag.FAILSAFE, 0x03)
class FailsafeDisarmReply(Reply):
    """The watchdog is off."""


@request_frame(FailsafeDisarmReply, extension=True, idempotent=True)
class FailsafeDisarm(Request[FailsafeDisarmReply]):
    """Turn the link watchdog off."""


@event_frame(0x02)
class FailsafeTripped(Event):
    """The link watchdog fired and applied the safe states."""
