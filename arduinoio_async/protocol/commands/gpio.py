"""GPIO commands (class tag 0x02) and change events, handled by ``firmware/src/gpio.c``.

Digital inputs and outputs, the edges latched between reads, pin release (any role), and
the GpioChange events a watched input sends by itself (docs/protocol.md 7.4).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag, GpioFlags, GpioState
from .._layout import U8, U16, U32
from .._messages import Event, OnePin, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "GpioChange",
    "GpioConfig",
    "GpioConfigReply",
    "GpioRead",
    "GpioReadReply",
    "GpioWatch",
    "GpioWatchReply",
    "GpioWrite",
    "GpioWriteReply",
    "PinRelease",
    "PinReleaseReply",
]


@echo
class _Config(OnePin):
    flags: Annotated[GpioFlags, U8]


@reply_frame(ClassTag.GPIO, 0x01)
class GpioConfigReply(_Config, Reply): ...


@request_frame(GpioConfigReply, idempotent=True)
class GpioConfig(_Config, Request[GpioConfigReply]):
    """Make a pin a digital input (optional pull-up) or output (initial level)."""


@reply_frame(ClassTag.GPIO, 0x02)
class GpioReadReply(OnePin, Reply):
    state: Annotated[GpioState, U8]

    def __post_init__(self) -> None:
        if self.state & ~0x07:
            raise ValueError(f"GPIO state {int(self.state):#04x} has undefined bits")

    @property
    def level(self) -> bool:
        return bool(self.state & GpioState.HIGH)

    @property
    def rose(self) -> bool:
        return bool(self.state & GpioState.ROSE)

    @property
    def fell(self) -> bool:
        return bool(self.state & GpioState.FELL)


# Not idempotent: a read clears the latched edges.
@request_frame(GpioReadReply)
class GpioRead(OnePin, Request[GpioReadReply]):
    """Read the level and the edges latched since the previous read (then cleared)."""


@echo
class _Write(OnePin):
    value: Annotated[bool, U8]


@reply_frame(ClassTag.GPIO, 0x03)
class GpioWriteReply(_Write, Reply): ...


@request_frame(GpioWriteReply, idempotent=True)
class GpioWrite(_Write, Request[GpioWriteReply]):
    """Set a digital output."""


@reply_frame(ClassTag.GPIO, 0x04)
class PinReleaseReply(OnePin, Reply): ...


@request_frame(PinReleaseReply, extension=True, idempotent=True)
class PinRelease(OnePin, Request[PinReleaseReply]):
    """Free a digital pin from any role (GPIO, PWM, counter): it becomes a plain input."""


@echo
class _Watch(OnePin):
    enable: Annotated[bool, U8]


@reply_frame(ClassTag.GPIO, 0x05)
class GpioWatchReply(_Watch, Reply): ...


@request_frame(GpioWatchReply, extension=True, idempotent=True)
class GpioWatch(_Watch, Request[GpioWatchReply]):
    """Report every change of a GPIO input as a GpioChange event (``enable`` 1) or stop.

    The pin must be a GPIO input; the subscription ends with ``enable`` 0, a new
    configuration of the pin, its release or a reset.
    """


@event_frame(0x03)
class GpioChange(OnePin, Event):
    """A watched input changed, seen by its pin-change interrupt (docs/protocol.md 7.4).

    ``state`` is the level now and the edge that led to it (ROSE or FELL);
    ``sequence`` counts every change event the board produced, sent or not (a full
    transmit buffer drops one), so the host sees a loss as a gap; ``timestamp_us`` is
    the board's clock when the interrupt ran.
    """

    state: Annotated[GpioState, U8]
    sequence: Annotated[int, U16]
    timestamp_us: Annotated[int, U32]

    def __post_init__(self) -> None:
        if self.state not in (GpioState.HIGH | GpioState.ROSE, GpioState.FELL):
            raise ValueError(f"GPIO change state {int(self.state):#04x} is not an edge")

    @property
    def level(self) -> bool:
        return bool(self.state & GpioState.HIGH)
