"""ENCODER commands (class tag 0x0A, extension) and reports, handled by ``firmware/src/encoder.c``.

Quadrature encoders on any two digital pins: the board decodes every edge of A and B in
an interrupt (INT0/INT1 for D2/D3, pin-change interrupts for the others), so no count is
lost however slowly the host reads.  An encoder lives in one of ``ENCODER_SLOTS`` slots
the host picks; the stream's ENCODERS values are the slots' counts in slot order.

Velocity comes from edge timing: every state (a read, a preset's reply, a report) carries
the board time of the last edge that changed the count, so two states give
``(count2 - count1) / (edge_us2 - edge_us1)`` exactly over whole edges, with no error from
when the host happened to ask (docs/sensors.md).

A skipped state (A and B changed between two interrupts: the encoder outran the board, or
a glitch) is an *invalid transition*: the board counts it in ``invalid`` and moves the
count two steps in the direction of the last valid step, which is right whenever the
encoder did not reverse within the skipped step.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag, EncoderMode
from .._layout import I32, U8, U16, U32
from .._messages import Event, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "EncoderConfig",
    "EncoderConfigReply",
    "EncoderPreset",
    "EncoderPresetReply",
    "EncoderRead",
    "EncoderReadReply",
    "EncoderReport",
    "EncoderWatch",
    "EncoderWatchReply",
]


@echo
class _Slot:
    slot: Annotated[int, U8]


@echo
class _SlotState(_Slot):
    """An encoder's state: its count, invalid transitions, and the last counting edge."""

    count: Annotated[int, I32]
    #: Invalid transitions (skipped states) since CONFIG or PRESET, 16 bit, wrapping.
    invalid: Annotated[int, U16]
    #: Board microseconds of the last edge that changed the count (0 before the first).
    edge_us: Annotated[int, U32]


@echo
class _Config(_Slot):
    pin_a: Annotated[int, U8]
    pin_b: Annotated[int, U8]
    mode: Annotated[EncoderMode, U8]


@reply_frame(ClassTag.ENCODER, 0x01)
class EncoderConfigReply(_Config, Reply): ...


# Not idempotent: a new configuration restarts the count.
@request_frame(EncoderConfigReply, extension=True)
class EncoderConfig(_Config, Request[EncoderConfigReply]):
    """Decode a quadrature encoder on ``pin_a``/``pin_b`` in ``slot``; the count starts at 0.

    A forward step is A leading B (A rises while B is low).  A slot in use is
    reconfigured; its old pins are released.
    """


@reply_frame(ClassTag.ENCODER, 0x02)
class EncoderReadReply(_SlotState, Reply): ...


@request_frame(EncoderReadReply, extension=True, reads_only=True)
class EncoderRead(_Slot, Request[EncoderReadReply]):
    """Read an encoder's count, invalid transitions and last edge time."""


@echo
class _Preset(_Slot):
    value: Annotated[int, I32]


@reply_frame(ClassTag.ENCODER, 0x03)
class EncoderPresetReply(_Preset, Reply):
    """The state just before the preset (so no edge falls between a read and a reset)."""

    count: Annotated[int, I32]
    invalid: Annotated[int, U16]
    edge_us: Annotated[int, U32]


# Not idempotent: it replaces the count the edges since moved.
@request_frame(EncoderPresetReply, extension=True)
class EncoderPreset(_Preset, Request[EncoderPresetReply]):
    """Set the count to ``value`` (0: a reset) and clear the invalid transitions."""


@echo
class _Watch(_Slot):
    every: Annotated[int, U16]


@reply_frame(ClassTag.ENCODER, 0x04)
class EncoderWatchReply(_Watch, Reply): ...


@request_frame(EncoderWatchReply, extension=True, idempotent=True)
class EncoderWatch(_Watch, Request[EncoderWatchReply]):
    """Send an EncoderReport every ``every`` counts moved either way (0 stops)."""


@event_frame(0x07)
class EncoderReport(_SlotState, Event):
    """A watched encoder moved another ``every`` counts (either way).

    Sent by the board's main loop, which adds up the distance moved between its passes
    (every interrupt ends one, so at most a few edges late): the count is the count then,
    ``every`` or a little more past the previous report's.  A report the transmit buffer
    had no room for is dropped, which the next report's count shows.
    """
