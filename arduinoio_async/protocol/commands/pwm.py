"""PWM commands (class tag 0x05), handled by ``firmware/src/pwm.c``.

Servo outputs: hardware PWM on D9/D10, software PWM on D2-D7.  Both commands carry and
echo the same pin and pulse width.  Duty-cycle PWM (extension): a timer's output
compare pins at a frequency the timer offers (``protocol.timers``).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U16
from .._messages import OnePin, Reply, Request, echo, reply_frame, request_frame

__all__ = [
    "PwmConfig",
    "PwmConfigReply",
    "PwmDutyConfig",
    "PwmDutyConfigReply",
    "PwmDutySet",
    "PwmDutySetReply",
    "PwmSet",
    "PwmSetReply",
]


@echo
class _Pulse(OnePin):
    pulse_us: Annotated[int, U16]


@reply_frame(ClassTag.PWM, 0x01)
class PwmConfigReply(_Pulse, Reply): ...


@request_frame(PwmConfigReply, idempotent=True)
class PwmConfig(_Pulse, Request[PwmConfigReply]):
    """Attach a servo output: hardware PWM on D9/D10, software PWM on D2-D7.

    ``pulse_us`` 0 attaches without pulses (line held low); otherwise PULSE_MIN_US-
    PULSE_MAX_US (500-2500), in steps of SOFT_PWM_STEP_US on software PWM pins.
    """


@reply_frame(ClassTag.PWM, 0x02)
class PwmSetReply(_Pulse, Reply): ...


@request_frame(PwmSetReply, idempotent=True)
class PwmSet(_Pulse, Request[PwmSetReply]):
    """Set the pulse width of an attached servo output (0 stops the pulses)."""


@echo
class _Duty(OnePin):
    duty: Annotated[int, U16]


@echo
class _DutyConfig(OnePin):
    frequency_hz: Annotated[int, U16]
    duty: Annotated[int, U16]


@reply_frame(ClassTag.PWM, 0x03)
class PwmDutyConfigReply(_DutyConfig, Reply): ...


@request_frame(PwmDutyConfigReply, extension=True, idempotent=True)
class PwmDutyConfig(_DutyConfig, Request[PwmDutyConfigReply]):
    """Duty-cycle PWM on a timer's pin (D3, D5, D6, D9, D10) at ``frequency_hz``.

    ``frequency_hz`` is one the pin's timer offers (``protocol.timers.DUTY_FREQUENCIES``;
    the pins of one timer share it) and ``duty`` is 0-DUTY_FULL of the period (0 = low,
    DUTY_FULL = high), rounded by the board to its timer's counts.  PIN_BUSY when the
    timer is taken by another user (servo PWM on Timer1, software PWM or a stream on
    Timer0, another duty pin at another frequency); VALUE_OUT_OF_RANGE for a frequency
    the timer does not give.
    """


@reply_frame(ClassTag.PWM, 0x04)
class PwmDutySetReply(_Duty, Reply): ...


@request_frame(PwmDutySetReply, extension=True, idempotent=True)
class PwmDutySet(_Duty, Request[PwmDutySetReply]):
    """New duty (0-DUTY_FULL) of a duty-cycle PWM pin; takes effect with the next period."""
