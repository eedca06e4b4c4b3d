"""The fake board's peripherals: pin state, and the I2C, PWM and counter command models.

Split from :mod:`._fake_board` by idea: these handlers follow the firmware's checks for
one peripheral each and touch only the state declared on :class:`PeripheralModels`;
the board's link, events and timers stay in the fake board itself.
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import protocol as p
from ..protocol.boards import BoardModel
from ..protocol.pins import DigitalPin, Function, pin_mask
from ..protocol.timers import DUTY_FREQUENCIES, TIMER_OF, Timer

__all__ = [
    "SOFT_PWM",
    "PeripheralModels",
    "PinModel",
    "check_pulse",
    "has",
]

E = p.ErrorCode

#: The Uno's software PWM pins (their widths are checked in SOFT_PWM_STEP_US steps); the
#: other pin checks ask the fake's model (``PeripheralModels._mask``).
SOFT_PWM = pin_mask(Function.SOFT_PWM)

#: The Mega's 16-bit timers by output compare pin (OC1A/B, OC3A-C, OC4A-C, OC5A-C; the
#: pins of protocol/boards.py's MEGA2560_HARDWARE duty map).  Each offers Timer1's table:
#: the same 16-bit counter with TOP = ICRn.
_MEGA_TIMER_OF: dict[int, int] = {
    11: 1, 12: 1, 5: 3, 2: 3, 3: 3, 6: 4, 7: 4, 8: 4, 46: 5, 45: 5, 44: 5,
}  # fmt: skip


def has(mask: int, pin: int) -> bool:
    return pin >= 0 and bool(mask >> pin & 1)


@dataclass
class PinModel:
    """One digital pin as the firmware keeps it (a reset makes a fresh one)."""

    role: str = "free"  # free | input | output | pwm | counter | duty | stepper
    pull_up: bool = False
    rose: bool = False
    fell: bool = False
    edge: p.Edge = p.Edge.RISING  # what a counter on this pin counts
    watched: bool = False  # GpioWatch: its changes are sent as GpioChange events
    report_every: int = 0  # CounterWatch: a CounterReport every this many counts
    since_report: int = 0


class PeripheralModels:
    """The I2C bridge, the pulse outputs and the counters (mixed into the FakeBoard)."""

    _pins: dict[int, PinModel]
    #: The board model the fake is (protocol/boards.py): its pins per function.
    model: BoardModel
    pulses: dict[int, int]
    duties: dict[int, tuple[int, int]]
    counters: dict[int, int]
    i2c_speed: p.I2CSpeed | None
    i2c_devices: dict[int, bytearray]

    def _mask(self, function: Function) -> int:
        """Bit n set when digital pin Dn of the fake's model can do ``function``."""
        return sum(1 << n for n in self.model.pin_numbers(function) if n < self.model.digital_pins)

    @staticmethod
    def _error(request: p.Frame, code: p.ErrorCode) -> p.ErrorReply:
        return p.ErrorReply(request.LAYOUT.class_tag, request.LAYOUT.descriptor, code)

    def _i2c_config(self, request: p.I2CConfig) -> p.Frame:
        self.i2c_speed = request.speed
        return p.I2CConfigReply(request.speed)

    def _i2c_device(self, request: p.I2CRead | p.I2CWrite) -> bytearray | p.ErrorReply:
        if self.i2c_speed is None:
            return self._error(request, E.I2C_NOT_CONFIGURED)
        stream = getattr(self, "stream", None)
        if stream is not None and stream.running and stream.request.flags & p.StreamFlags.I2C:
            return self._error(request, E.I2C_STREAMING)  # the stream's reads own the bus
        if request.address > 0x7F:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        device = self.i2c_devices.get(request.address)
        return device if device is not None else self._error(request, E.I2C_NACK_ADDRESS)

    def _i2c_read(self, request: p.I2CRead) -> p.Frame:
        device = self._i2c_device(request)
        if isinstance(device, p.ErrorReply):
            return device
        if not 1 <= request.length <= p.I2C_MAX_LENGTH:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        data = bytes(device[(request.register + i) % 256] for i in range(request.length))
        return p.I2CReadReply(request.address, request.register, data)

    def _i2c_write(self, request: p.I2CWrite) -> p.Frame:
        device = self._i2c_device(request)
        if isinstance(device, p.ErrorReply):
            return device
        for i, byte in enumerate(request.data):
            device[(request.register + i) % 256] = byte
        return p.I2CWriteReply(request.address, request.register, len(request.data))

    def _pwm(self, request: p.PwmConfig | p.PwmSet) -> p.Frame:
        pin, pulse = request.pin, request.pulse_us
        soft = has(self._mask(Function.SOFT_PWM), pin)
        if not (soft or has(self._mask(Function.SERVO_PWM), pin)):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[pin]
        if isinstance(request, p.PwmConfig):
            if state.role not in ("free", "pwm"):
                return self._error(request, E.PIN_BUSY)
            if self._duty_timer_busy(Timer.TIMER0 if soft else self._timer_of(pin)):
                return self._error(request, E.PIN_BUSY)  # duty PWM holds the timer
        elif state.role != "pwm":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        error = check_pulse(pin, pulse, soft=soft)
        if error is not None:
            return self._error(request, error)
        state.role = "pwm"
        self.pulses[pin] = pulse
        if isinstance(request, p.PwmConfig):
            return p.PwmConfigReply(pin, pulse)
        return p.PwmSetReply(pin, pulse)

    def _timer_of(self, pin: int) -> int:
        """The timer whose output compare unit drives ``pin`` on this board's model."""
        if self.model.key == "mega2560":
            return _MEGA_TIMER_OF[pin]
        return TIMER_OF[DigitalPin(pin)]

    def _servo_pins_of(self, timer: int, pin: int) -> list[int]:
        """The other servo-capable pins of ``timer`` (they would share its period)."""
        return [
            n
            for n in self.model.pin_numbers(Function.SERVO_PWM)
            if n != pin and n in self._pins and self._timer_of_or_none(n) == timer
        ]

    def _timer_of_or_none(self, pin: int) -> int | None:
        try:
            return self._timer_of(pin)
        except KeyError:
            return None

    def _duty_timer_busy(self, timer: int) -> bool:
        """Duty-cycle PWM holds ``timer`` (the firmware's duty_timer_busy)."""
        return any(
            self._pins[pin].role == "duty" and self._timer_of(pin) == timer for pin in self.duties
        )

    def _timer_taken(self, pin: int, timer: int, hz: int) -> bool:
        """Another user holds ``pin``'s timer (the firmware's timer_taken)."""
        for other, (other_hz, _duty) in self.duties.items():
            same_timer = self._timer_of(other) == timer
            if other != pin and same_timer and other_hz != hz and self._pins[other].role == "duty":
                return True
        if timer != Timer.TIMER0 and any(
            self._pins[n].role == "pwm" and not has(self._mask(Function.SOFT_PWM), n)
            for n in self._servo_pins_of(timer, pin)
        ):
            return True  # servo PWM (a 20 ms period) on another pin of the timer
        if timer is Timer.TIMER0:
            stream = getattr(self, "stream", None)
            if stream is not None and stream.running:
                return True
            return any(self._pins[n].role == "pwm" for n in range(2, 8))
        return False

    def _duty(self, request: p.PwmDutyConfig | p.PwmDutySet) -> p.Frame:
        pin = request.pin
        if not has(self._mask(Function.DUTY_PWM), pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[pin]
        if isinstance(request, p.PwmDutySet):
            if state.role != "duty":
                return self._error(request, E.PIN_NOT_CONFIGURED)
            self.duties[pin] = (self.duties[pin][0], request.duty)
            return p.PwmDutySetReply(pin, request.duty)
        if state.role not in ("free", "duty"):
            return self._error(request, E.PIN_BUSY)
        timer = self._timer_of(pin)
        offered = DUTY_FREQUENCIES[Timer(timer) if timer < 3 else Timer.TIMER1]
        if request.frequency_hz not in offered:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if self._timer_taken(pin, timer, request.frequency_hz):
            return self._error(request, E.PIN_BUSY)
        state.role = "duty"
        self.duties[pin] = (request.frequency_hz, request.duty)
        return p.PwmDutyConfigReply(pin, request.frequency_hz, request.duty)

    def _counter_config(self, request: p.CounterConfig) -> p.Frame:
        if not has(self._mask(Function.COUNTER), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[request.pin]
        if state.role not in ("free", "counter"):
            return self._error(request, E.PIN_BUSY)
        if int(request.edge) not in (p.Edge.FALLING, p.Edge.RISING):
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        state.role = "counter"
        state.edge = p.Edge(request.edge)
        state.report_every = state.since_report = 0  # a new configuration ends a watch
        self.counters[request.pin] = 0
        return p.CounterConfigReply(request.pin, request.edge)

    def _counter_read(self, request: p.CounterRead | p.CounterReset) -> p.Frame:
        if not has(self._mask(Function.COUNTER), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self._pins[request.pin].role != "counter":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        count = self.counters[request.pin]
        if isinstance(request, p.CounterReset):
            self.counters[request.pin] = 0
            return p.CounterResetReply(request.pin, count)
        return p.CounterReadReply(request.pin, count)

    def _counter_watch(self, request: p.CounterWatch) -> p.Frame:
        if not has(self._mask(Function.COUNTER), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[request.pin]
        if state.role != "counter":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        state.report_every, state.since_report = request.every, 0
        return p.CounterWatchReply(request.pin, request.every)


def check_pulse(pin: int, pulse: int, *, soft: bool | None = None) -> p.ErrorCode | None:
    """The firmware's pulse-width rule: 0 (off) or the servo range, soft PWM in steps.

    ``soft`` says whether ``pin`` is a software PWM pin of the board's model (None: the
    Uno's, for callers without a model)."""
    valid = pulse == 0 or p.PULSE_MIN_US <= pulse <= p.PULSE_MAX_US
    soft_pin = has(SOFT_PWM, pin) if soft is None else soft
    if not valid or (soft_pin and pulse % p.SOFT_PWM_STEP_US):
        return E.VALUE_OUT_OF_RANGE
    return None
