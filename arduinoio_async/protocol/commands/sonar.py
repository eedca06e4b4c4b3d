"""SONAR commands (class tag 0x0B, extension), handled by ``firmware/src/sonar.c``.

HC-SR04 style ultrasonic rangers: a trigger pin (a >= 10 us high pulse starts a
measurement) and an echo pin (high for the sound's round trip).  The board fires the
configured sonars one at a time, in slot order, so one cannot hear another's ping: the
next fires only after the previous echo ended (or ``SONAR_TIMEOUT_US`` passed without
one) and at least ``period_ms`` after the previous firing.  The echo's width is timed on
the board from the pin-change interrupt's stamps of both edges (the shared edge-timing
layer, ``firmware/src/pulse.h``), so it is the board's measurement, not a host round
trip's; the distance is ``echo_us * speed / 2``.

A firing with no echo that ends in time reads ``SONAR_NO_ECHO`` (nothing in range: the
HC-SR04 holds its echo high for ~38 ms then), never a distance; a slot not fired yet
reads ``SONAR_NO_READING``.  Every reading carries its age, so an old distance is never
taken for a fresh one.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U8, U16
from .._messages import Reply, Request, echo, reply_frame, request_frame

__all__ = [
    "SonarConfig",
    "SonarConfigReply",
    "SonarRead",
    "SonarReadReply",
    "SonarTiming",
    "SonarTimingReply",
]


@echo
class _Slot:
    slot: Annotated[int, U8]


@echo
class _Config(_Slot):
    trigger: Annotated[int, U8]
    echo: Annotated[int, U8]


@reply_frame(ClassTag.SONAR, 0x01)
class SonarConfigReply(_Config, Reply): ...


# Not idempotent: a new configuration forgets the last reading.
@request_frame(SonarConfigReply, extension=True)
class SonarConfig(_Config, Request[SonarConfigReply]):
    """Fire a sonar with its trigger on ``trigger`` and its echo on ``echo`` in ``slot``.

    A slot in use is reconfigured; its old pins are released.  The slot reads
    SONAR_NO_READING until its first firing ends.
    """


@reply_frame(ClassTag.SONAR, 0x02)
class SonarReadReply(_Slot, Reply):
    """A sonar's last reading."""

    #: Millimetres to the echo (SONAR_NO_ECHO: none heard; SONAR_NO_READING: not fired yet).
    distance_mm: Annotated[int, U16]
    #: The echo's width in microseconds (0 without a distance).
    echo_us: Annotated[int, U16]
    #: Milliseconds since that reading (65535 at most, and before the first).
    age_ms: Annotated[int, U16]
    #: Readings since CONFIG, 16 bit, wrapping (a new reading changes it).
    readings: Annotated[int, U16]


@request_frame(SonarReadReply, extension=True, reads_only=True)
class SonarRead(_Slot, Request[SonarReadReply]):
    """Read a sonar's last distance, its echo width, its age and the readings so far."""


@echo
class _Timing:
    #: Milliseconds from one firing to the next (the round robin's step), 1-65535.
    period_ms: Annotated[int, U16]
    #: The speed of sound in 0.1 m/s (3,000-4,000; 3,430 = 343.0 m/s, air at 20 C).
    speed_dm_s: Annotated[int, U16]


@reply_frame(ClassTag.SONAR, 0x03)
class SonarTimingReply(_Timing, Reply): ...


@request_frame(SonarTimingReply, extension=True, idempotent=True)
class SonarTiming(_Timing, Request[SonarTimingReply]):
    """Set every sonar's firing period and the speed of sound the distances use.

    A sonar fires at most every ``period_ms`` (one at a time: with n sonars each fires
    every n periods), and never before the previous echo ended or timed out.  Boot:
    60 ms and 343.0 m/s.
    """
