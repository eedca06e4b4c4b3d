"""Duty-cycle PWM and DC motors behind H-bridges (an extension of the paper).

:class:`DutyPwm` is Arduino's ``analogWrite``: a hardware timer's output compare pin
(D3, D5, D6, D9, D10) high for a fraction of every period, at a frequency the pin's timer
offers (:mod:`arduinoio_async.protocol.timers`).  The pins of a timer share its frequency,
and a timer has other users (servo PWM on Timer1, the software PWM and stream alarms on
Timer0), so :func:`check_timer` refuses a conflict before anything is sent, with a message
that names the other user; the board refuses it too (PIN_BUSY).

:class:`Motor` drives one DC motor through its driver's inputs: a PWM pin for the speed
plus one or two direction pins (L298N EN/IN1/IN2, TB6612 PWM/IN1/IN2, or a driver with a
single DIR input), or two PWM pins (DRV8833 IN1/IN2).  Its speed is signed, -1..1; it can
brake (both motor terminals tied together: the motor stops fast) or coast (terminals
open: it spins down).  Armed in the failsafe (``board.arm_failsafe(t, {motor: 0})``) a
motor's safe state is stopped: every PWM pin it has goes to duty 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import protocol as p
from ..errors import TimerBusyError, ValueRangeError
from ..protocol.pins import DigitalPin
from ..protocol.timers import DUTY_FREQUENCIES, TIMER_OF, Timer, duty_steps
from .handles import DigitalOutput, PinHandle, Servo, SoftPwm

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = [
    "DEFAULT_FREQUENCY",
    "DutyPwm",
    "Motor",
    "check_stream",
    "check_timer",
    "resolve_frequency",
]

#: The frequency a duty PWM pin gets unless told: Arduino's ``analogWrite`` ones on
#: Timer0 (976 Hz) and Timer1 (490 Hz), the board tick's on Timer2.
DEFAULT_FREQUENCY: dict[Timer, int] = {Timer.TIMER0: 976, Timer.TIMER1: 490, Timer.TIMER2: 10000}

_SOFT_PWM_PINS = range(2, 8)


class DutyPwm(PinHandle):
    """Duty-cycle PWM on a timer's pin: high for ``duty`` (0-1) of every period."""

    ROLE = "duty-cycle PWM"

    def __init__(self, board: BoardCore, pin: DigitalPin) -> None:
        super().__init__(board, pin)
        #: The timer's frequency (nominal Hz, as sent): shared by the timer's duty pins.
        self.frequency_hz = 0
        #: The duty last acknowledged by the board, 0.0-1.0.
        self.duty = 0.0

    @property
    def timer(self) -> Timer:
        """The hardware timer whose compare unit drives this pin."""
        return TIMER_OF[self.pin]

    @property
    def steps(self) -> int:
        """The duty's resolution at this frequency: timer counts in one period."""
        return duty_steps(self.timer, self.frequency_hz)

    @staticmethod
    def check_duty(duty: float) -> int:
        """The wire value (0-DUTY_FULL) of a duty 0.0-1.0, refused outside that range."""
        if isinstance(duty, bool) or not 0.0 <= duty <= 1.0:
            raise ValueRangeError("PWM duty", duty, "0.0-1.0 (0 = always low, 1 = always high)")
        return round(duty * p.DUTY_FULL)

    async def set_duty(self, duty: float) -> None:
        """High for ``duty`` (0.0-1.0) of every period, from the next period on; the board
        rounds it to :attr:`steps`.  Recorded, so a reset or reconnect restores it."""
        self.check_usable()
        raw = self.check_duty(duty)
        reply = await self.board.request(p.PwmDutySet(self.pin, raw))
        self.duty = reply.duty / p.DUTY_FULL
        self.board.roles.amend(self, p.PwmDutyConfig(self.pin, self.frequency_hz, reply.duty))

    async def stop(self) -> None:
        """Duty 0: the pin held low (the pin keeps its role)."""
        await self.set_duty(0.0)


def _conflict(pin: DigitalPin, other: DigitalPin, holder: PinHandle, wanted: str, msg: str) -> None:
    raise TimerBusyError(pin.name, f"{holder.ROLE} on {other.name}", wanted, msg)


def check_timer(board: BoardCore, pin: DigitalPin, wanted: str, frequency_hz: int = 0) -> None:
    """Raise :class:`TimerBusyError` if ``pin`` cannot take ``wanted`` because another
    pin's role holds the timer it needs (the firmware's PIN_BUSY rules, checked first).

    ``wanted`` is a handle ROLE: duty-cycle PWM (at ``frequency_hz``), servo PWM or
    software PWM.
    """
    timer = TIMER_OF.get(pin)
    at = f" at {frequency_hz} Hz" if frequency_hz else ""
    if wanted == DutyPwm.ROLE and timer is Timer.TIMER0 and _streaming(board):
        raise TimerBusyError(
            pin.name,
            "stream sampling",
            wanted,
            f"{pin.name} is on Timer0, whose alarms time the stream that runs: {pin.name} "
            f"cannot take {wanted} until the stream ends",
        )
    for other, claim in board.roles.items():
        holder = claim.handle
        if other == pin:
            continue
        same_timer = timer is not None and TIMER_OF.get(other) is timer
        if (
            wanted == DutyPwm.ROLE
            and same_timer
            and (
                isinstance(holder, Servo)
                or (isinstance(holder, DutyPwm) and holder.frequency_hz != frequency_hz)
            )
        ):
            its = f" at {holder.frequency_hz} Hz" if isinstance(holder, DutyPwm) else ""
            _conflict(
                pin,
                other,
                holder,
                wanted,
                f"{pin.name} and {other.name} share {timer}: {other.name} is {holder.ROLE}"
                f"{its}, so {pin.name} cannot take {wanted}{at}",
            )
        if wanted == DutyPwm.ROLE and timer is Timer.TIMER0 and isinstance(holder, SoftPwm):
            _conflict(
                pin,
                other,
                holder,
                wanted,
                f"{pin.name} is on Timer0, whose alarms run {holder.ROLE} on {other.name}: "
                f"{pin.name} cannot take {wanted} until it is released",
            )
        if isinstance(holder, DutyPwm) and (
            (wanted == Servo.ROLE and holder.timer is Timer.TIMER1)
            or (wanted == SoftPwm.ROLE and holder.timer is Timer.TIMER0)
        ):
            _conflict(
                pin,
                other,
                holder,
                wanted,
                f"{wanted} needs {holder.timer}, which {other.name} holds for {holder.ROLE} "
                f"at {holder.frequency_hz} Hz, so {pin.name} cannot take {wanted}",
            )


def _streaming(board: BoardCore) -> bool:
    return any(isinstance(r, p.StreamStart) for r in board.watches.requests())


def check_stream(board: BoardCore) -> None:
    """Raise :class:`TimerBusyError` if duty PWM holds Timer0, whose alarms time a stream's
    samples (the firmware refuses STREAM_START then with PIN_BUSY)."""
    for pin, claim in board.roles.items():
        holder = claim.handle
        if isinstance(holder, DutyPwm) and holder.timer is Timer.TIMER0:
            raise TimerBusyError(
                pin.name,
                f"{holder.ROLE} on {pin.name}",
                "stream sampling",
                f"a stream's samples are timed by Timer0, which {pin.name} holds for "
                f"{holder.ROLE} at {holder.frequency_hz} Hz: release it first",
            )


def resolve_frequency(board: BoardCore, pin: DigitalPin, frequency_hz: int | None) -> int:
    """The frequency ``pin`` will run at: ``frequency_hz`` if its timer offers it, else
    (None) the one the timer's other duty pin runs at, or the timer's default."""
    timer = TIMER_OF[pin]
    offered = DUTY_FREQUENCIES[timer]
    if frequency_hz is None:
        for other, claim in board.roles.items():
            holder = claim.handle
            if other != pin and isinstance(holder, DutyPwm) and holder.timer is timer:
                return holder.frequency_hz
        return DEFAULT_FREQUENCY[timer]
    if frequency_hz not in offered:
        raise ValueRangeError(
            f"PWM frequency (Hz) on {pin.name} ({timer})",
            frequency_hz,
            "one of " + ", ".join(str(hz) for hz in offered),
        )
    return frequency_hz


class Motor:
    """One DC motor behind an H-bridge: signed speed, brake and coast.

    Made by ``board.motor(pwm, direction)`` (one direction input), ``board.motor(pwm,
    in1, in2)`` (L298N/TB6612: EN or PWM plus IN1/IN2) or ``board.motor_2pwm(in1, in2)``
    (DRV8833: both inputs PWM).  Brake ties the motor's terminals together (IN1 = IN2
    high, or both PWM inputs full on); coast leaves them open (PWM 0).  With a single
    direction input there is no brake: :meth:`brake` coasts.
    """

    def __init__(
        self,
        speed_pins: tuple[DutyPwm, ...],
        directions: tuple[DigitalOutput, ...] = (),
    ) -> None:
        self.speed_pins = speed_pins
        self.directions = directions
        self._levels: tuple[bool, ...] = (False,) * len(directions)  # they start low
        #: The speed last set, -1.0..1.0 (0 after brake or coast).
        self.speed = 0.0
        #: "running", "brake" or "coast": what the motor's terminals see.
        self.state = "coast"

    def __repr__(self) -> str:
        pins = ", ".join(h.pin.name for h in (*self.speed_pins, *self.directions))
        return f"<Motor {pins} {self.state} {self.speed:+.2f}>"

    @property
    def pwm_handles(self) -> tuple[DutyPwm, ...]:
        """The duty PWM pins: what the failsafe stops (duty 0)."""
        return self.speed_pins

    async def _directions(self, *levels: bool) -> None:
        """Set the direction inputs (only those that change) with the enable at duty 0:
        never a reversal under drive, nor full power on the way out of a brake."""
        levels = levels[: len(self.directions)]
        if levels == self._levels:
            return
        if self.state != "coast":  # running or braking (enable full on): drive off first
            await self.speed_pins[0].set_duty(0.0)
            self.state = "coast"
        for handle, old, new in zip(self.directions, self._levels, levels, strict=True):
            if old != new:
                await handle.write(new)
        self._levels = levels

    async def set_speed(self, speed: float) -> None:
        """Signed speed -1.0..1.0: the sign picks the direction, the magnitude the duty."""
        if isinstance(speed, bool) or not -1.0 <= speed <= 1.0:
            raise ValueRangeError("motor speed", speed, "-1.0..1.0 (negative = reverse)")
        magnitude = abs(speed)
        forward = speed >= 0
        if len(self.speed_pins) == 2:  # DRV8833: PWM on one input, the other low
            on, off = self.speed_pins if forward else self.speed_pins[::-1]
            await off.set_duty(0.0)
            await on.set_duty(magnitude)
        else:
            await self._directions(forward, not forward)
            await self.speed_pins[0].set_duty(magnitude)
        self.speed = speed
        self.state = "running" if magnitude else "coast"

    async def brake(self) -> None:
        """Short the motor's terminals (stops fast); coasts with a single DIR input."""
        if len(self.speed_pins) == 2:
            for handle in self.speed_pins:
                await handle.set_duty(1.0)
        elif len(self.directions) == 2:
            await self._directions(True, True)
            await self.speed_pins[0].set_duty(1.0)
        else:
            await self.coast()
            return
        self.speed = 0.0
        self.state = "brake"

    async def coast(self) -> None:
        """Leave the terminals open: no drive, the motor spins down by itself."""
        for handle in self.speed_pins:
            await handle.set_duty(0.0)
        self.speed = 0.0
        self.state = "coast"

    async def release(self) -> None:
        """Coast, then end every pin's role so the pins may serve something else."""
        await self.coast()
        for handle in (*self.speed_pins, *self.directions):
            await handle.release()
