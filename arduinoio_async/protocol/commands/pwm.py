"""PWM commands (class tag 0x05), handled by ``firmware/src/pwm.c``.

Servo outputs: hardware PWM on D9/D10, software PWM on D2-D7.  Both commands carry and
echo the same pin and pulse width.
"""

from __future__ import annotations

from typing import Annotated

from .._constants import ClassTag
from .._layout import U16
from .._messages import OnePin, Reply, Request, echo, reply_frame, request_frame

__all__ = ["PwmConfig", "PwmConfigReply", "PwmSet", "PwmSetReply"]


@echo
class _Pulse(OnePin):
    pulse_us: Annotated[int, U16]


@reply_frame(ClassTag.PWM, 0x01)
class PwmConfigReply(_Pulse, Reply): ...


@request_frame(PwmConfigReply, idempotent=True)
class PwmConfig(_Pulse, Request[PwmConfigReply]):
    """Attach a servo output: hardware PWM on D9/D10, software PWM on D2-D7.

    ``pulse_us`` 0 attaches without pulses (line held low); otherwise 1000-2000, in steps
    of SOFT_PWM_STEP_US on software PWM pins.
    """


@reply_frame(ClassTag.PWM, 0x02)
class PwmSetReply(_Pulse, Reply): ...


@request_frame(PwmSetReply, idempotent=True)
class PwmSet(_Pulse, Request[PwmSetReply]):
    """Set the pulse width of an attached servo output (0 stops the pulses)."""
