"""The board's actuator methods (servos, duty-cycle PWM, motors), mixed into
:class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: they only combine the board's pin-role machinery
(``_new_handle`` of :mod:`._pin_methods`, ``set_up``, ``roles``) with
:mod:`arduinoio_async.board.motors`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar, cast

from .. import protocol as p
from ..errors import PinCapabilityError
from ..protocol.pins import (
    D11,
    DigitalPin,
    DutyPwmPin,
    Function,
    ServoPin,
    SoftPwmPin,
)
from ..protocol.timers import TIMER_OF
from ._pin_methods import PinMethods
from .handles import PulseOutput, Servo, SoftPwm
from .motors import DutyPwm, Motor, check_timer, resolve_frequency

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["MotorMethods"]

PO = TypeVar("PO", bound=PulseOutput)

#: Why D11, a PWM pin on Arduino's pinout, is not one here.
D11_REASON = (
    "; D11 (OC2A) cannot: Timer2's OCR2A sets the board tick's 100 us period "
    "(docs/motors.md, 'Timers and pins')"
)


class MotorMethods(PinMethods):
    """``board.servo()``, ``board.soft_pwm()``, ``board.pwm()``, ``board.motor()`` and
    ``board.motor_2pwm()``: the board's actuator outputs."""

    async def _pulse_output(
        self,
        pin: DigitalPin,
        function: Function,
        cls: type[PO],
        pulse_us: int,
        limits: tuple[int, int],
    ) -> PO:
        board = cast("BoardCore", self)
        handle = self._new_handle(pin, function, cls)
        check_timer(board, handle.pin, cls.ROLE)  # duty PWM may hold the timer it needs
        handle.set_limits(*limits)
        pulse_us = handle.check_pulse(pulse_us)
        await board.set_up(handle, p.PwmConfig(handle.pin, pulse_us))
        handle.pulse_us = pulse_us
        return handle

    async def servo(
        self,
        pin: ServoPin,
        *,
        pulse_us: int = 0,
        min_us: int = p.SERVO_DEFAULT_MIN_US,
        max_us: int = p.SERVO_DEFAULT_MAX_US,
    ) -> Servo:
        """Hardware servo PWM on D9/D10 (1 us resolution); ``pulse_us`` 0 = no pulses yet.

        ``min_us``-``max_us`` are this servo's limits (1,000-2,000 us unless widened, up
        to 500-2,500 us): wider widths are refused, ``set_angle`` maps onto them.
        """
        limits = (min_us, max_us)
        return await self._pulse_output(pin, Function.SERVO_PWM, Servo, pulse_us, limits)

    async def soft_pwm(
        self,
        pin: SoftPwmPin,
        *,
        pulse_us: int = 0,
        min_us: int = p.SERVO_DEFAULT_MIN_US,
        max_us: int = p.SERVO_DEFAULT_MAX_US,
    ) -> SoftPwm:
        """Software servo PWM on D2-D7 (1 us resolution); limits as for :meth:`servo`."""
        limits = (min_us, max_us)
        return await self._pulse_output(pin, Function.SOFT_PWM, SoftPwm, pulse_us, limits)

    async def pwm(
        self, pin: DutyPwmPin, duty: float = 0.0, *, frequency_hz: int | None = None
    ) -> DutyPwm:
        """Duty-cycle PWM (Arduino's ``analogWrite``) on D3, D5, D6, D9 or D10.

        ``duty`` 0.0-1.0; ``frequency_hz`` one the pin's timer offers
        (``protocol.timers.DUTY_FREQUENCIES``: Timer1 on D9/D10 31250-244 Hz up to 16 bits,
        Timer0 on D5/D6 62500-61 Hz, 8 bits, Timer2 on D3 the tick's 10000 Hz, 200 steps);
        None takes the frequency the timer's other duty pin runs at, else the timer's
        default (976/490/10000 Hz).  Raises PinCapabilityError for another pin,
        ValueRangeError for a frequency the timer does not give, TimerBusyError when
        another user holds the timer (servo PWM on Timer1, software PWM on Timer0, the
        other pin at another frequency), PinRoleError when the pin has another role.
        """
        board = cast("BoardCore", self)
        if cast(object, pin) is D11 and board.model.model_id == p.BoardModelId.UNO_R3:
            capable = list(board.model.pin_names(Function.DUTY_PWM))
            exc = PinCapabilityError("D11", Function.DUTY_PWM.value, capable)
            exc.args = (exc.args[0] + D11_REASON,)
            raise exc
        handle = self._new_handle(pin, Function.DUTY_PWM, DutyPwm)
        hz = resolve_frequency(board, handle.pin, frequency_hz)
        check_timer(board, handle.pin, DutyPwm.ROLE, hz)
        raw = DutyPwm.check_duty(duty)
        handle.frequency_hz = hz
        await board.set_up(handle, p.PwmDutyConfig(handle.pin, hz, raw))
        handle.duty = raw / p.DUTY_FULL
        return handle

    async def motor(
        self,
        pwm: DutyPwmPin,
        direction: DigitalPin,
        direction2: DigitalPin | None = None,
        *,
        frequency_hz: int | None = None,
    ) -> Motor:
        """A motor behind an EN/PWM + IN1 [+ IN2] driver (L298N, TB6612, MD10C...).

        ``pwm`` carries the speed, ``direction`` (IN1) is high going forward; with
        ``direction2`` (IN2, low going forward) the motor can also brake.  Every pin is
        checked before any is taken.
        """
        return await _build(self, (pwm,), (direction, direction2), frequency_hz)

    async def motor_2pwm(
        self, in1: DutyPwmPin, in2: DutyPwmPin, *, frequency_hz: int | None = None
    ) -> Motor:
        """A motor behind a two-PWM driver (DRV8833 IN1/IN2): forward drives IN1 with
        PWM and holds IN2 low, reverse the other way round; brake holds both high.
        Both pins share one frequency, so a timer's pair (D9/D10, D5/D6) suits best."""
        return await _build(self, (in1, in2), (), frequency_hz)


async def _build(
    board: MotorMethods,
    pwm_pins: tuple[DutyPwmPin, ...],
    direction_pins: tuple[DigitalPin | None, ...],
    frequency_hz: int | None,
) -> Motor:
    directions = [pin for pin in direction_pins if pin is not None]
    pins: list[DigitalPin] = [*pwm_pins, *directions]
    if len(set(pins)) != len(pins):
        raise ValueError(f"a motor needs distinct pins, got {', '.join(str(q) for q in pins)}")
    for pin in pwm_pins:  # check all before taking any
        if pin in TIMER_OF:
            core = cast("BoardCore", board)
            check_timer(core, pin, DutyPwm.ROLE, resolve_frequency(core, pin, frequency_hz))
    taken: list[DutyPwm] = []
    outs = []
    try:
        for speed_pin in pwm_pins:
            taken.append(await board.pwm(speed_pin, 0.0, frequency_hz=frequency_hz))
            frequency_hz = taken[-1].frequency_hz
        for direction in directions:
            outs.append(await board.digital_output(direction, initial=False))
    except BaseException:
        for handle in (*taken, *outs):
            if not handle.released:
                await handle.release()
        raise
    return Motor(tuple(taken), tuple(outs))
