"""Every request in words, for error messages: "make D4 a digital output (initially high)".

One entry per request class, beside the command table, so a new request without words
fails a test (``tests/test_error_text.py``) instead of reaching a user as a repr.  Each
entry completes "the board refused to ...", so it is a verb phrase in the infinitive.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ...errors import set_request_words
from .._constants import (
    DUTY_FULL,
    Edge,
    Framing,
    GpioFlags,
    I2CSpeed,
    SafeKind,
    SpiClock,
    StreamFlags,
)
from .._messages import Request
from ..pins import AnalogPin, DigitalPin, Function, pin_mask
from . import (
    analog,
    counter,
    encoder,
    failsafe,
    gpio,
    i2c,
    misc,
    pulse_in,
    pwm,
    sonar,
    spi,
    stepper,
    stream,
    transaction,
)

__all__ = ["DESCRIPTIONS", "describe"]


def _pin(number: int) -> str:
    try:
        return DigitalPin(number).name
    except ValueError:
        return f"pin {number}"


def _channel(number: int) -> str:
    try:
        return AnalogPin(number).name
    except ValueError:
        return f"analog channel {number}"


def _bytes(count: int) -> str:
    return f"{count} byte" if count == 1 else f"{count} bytes"


def _gpio_config(rq: gpio.GpioConfig) -> str:
    pin = _pin(rq.pin)
    if rq.flags & GpioFlags.OUTPUT:
        level = "high" if rq.flags & GpioFlags.INITIAL_HIGH else "low"
        return f"make {pin} a digital output (initially {level})"
    pull_up = " with pull-up" if rq.flags & GpioFlags.PULL_UP else ""
    return f"make {pin} a digital input{pull_up}"


def _pwm_kind(number: int) -> str:
    return "servo PWM" if pin_mask(Function.SERVO_PWM) >> number & 1 else "software PWM"


def _duty(duty: int) -> str:
    return f"{duty * 100 / DUTY_FULL:.1f} %"


def _i2c_speed(speed: I2CSpeed) -> str:
    return "400 kHz" if speed == I2CSpeed.KHZ_400 else "100 kHz"


def _stream_start(rq: stream.StreamStart) -> str:
    parts = [_channel(bit) for bit in range(8) if rq.analog_mask >> bit & 1]
    parts += [str(flag.name).lower() for flag in StreamFlags if flag.name and rq.flags & flag]
    what = f" of {', '.join(parts)}" if parts else ""
    return f"stream samples{what} every {rq.period_us / 1000:g} ms"


def _safe_state(rq: failsafe.FailsafeSafeState) -> str:
    pin = _pin(rq.pin)
    if rq.kind == SafeKind.LEVEL:
        return f"give {pin} the safe level {'high' if rq.value else 'low'}"
    if rq.kind == SafeKind.PULSE:
        pulse = f"{rq.value} us pulses" if rq.value else "no pulses"
        return f"give {pin} the safe state of {pulse}"
    return f"give {pin} no safe state"


#: Request class -> its words (a function of the request's fields).
DESCRIPTIONS: dict[type[Request[Any]], Callable[[Any], str]] = {
    misc.Reset: lambda rq: "reset",
    misc.ReadId: lambda rq: "report its board ID",
    misc.ReadTemperature: lambda rq: "read its temperature",
    misc.ReadCapabilities: lambda rq: "report its capabilities",
    misc.WriteId: lambda rq: f"store the board ID 0x{rq.board_id:04X}",
    misc.ReadStatus: lambda rq: "report its status",
    misc.SetSession: lambda rq: f"take the session tag 0x{rq.session:04X}",
    misc.ReadPinRoles: lambda rq: "report its pin roles",
    misc.ReadBoardDescription: lambda rq: f"describe its pins (page {rq.page})",
    transaction.Transaction: lambda rq: "run a transaction",
    misc.SetLowLatency: lambda rq: f"turn low-latency mode {'on' if rq.enabled else 'off'}",
    misc.SetFraming: lambda rq: (
        "check frames by CRC-16" if rq.framing == Framing.CRC16 else "check frames by XOR"
    ),
    gpio.GpioConfig: _gpio_config,
    gpio.GpioRead: lambda rq: f"read {_pin(rq.pin)}",
    gpio.GpioWrite: lambda rq: f"set {_pin(rq.pin)} {'high' if rq.value else 'low'}",
    gpio.PinRelease: lambda rq: f"release {_pin(rq.pin)}",
    gpio.GpioWatch: lambda rq: (
        f"report every change of {_pin(rq.pin)}"
        if rq.enable
        else f"stop reporting the changes of {_pin(rq.pin)}"
    ),
    analog.AnalogRead: lambda rq: f"read {_channel(rq.channel)}",
    analog.AnalogReadAll: lambda rq: "read every analog input",
    analog.AnalogWatch: lambda rq: (
        f"report {_channel(rq.channel)} when it moves by more than {rq.deadband} counts"
        if rq.deadband
        else f"stop reporting the moves of {_channel(rq.channel)}"
    ),
    i2c.I2CConfig: lambda rq: f"turn on the I2C bus at {_i2c_speed(rq.speed)}",
    i2c.I2CRead: lambda rq: (
        f"read {_bytes(rq.length)} from register 0x{rq.register:02X} "
        f"of I2C device 0x{rq.address:02X}"
    ),
    i2c.I2CWrite: lambda rq: (
        f"write {_bytes(len(rq.data))} to register 0x{rq.register:02X} "
        f"of I2C device 0x{rq.address:02X}"
    ),
    pwm.PwmConfig: lambda rq: (
        f"make {_pin(rq.pin)} a {_pwm_kind(rq.pin)} output ({rq.pulse_us} us pulses)"
    ),
    pwm.PwmSet: lambda rq: f"set the pulses of {_pin(rq.pin)} to {rq.pulse_us} us",
    pwm.PwmDutyConfig: lambda rq: (
        f"make {_pin(rq.pin)} a duty-cycle PWM output at {rq.frequency_hz} Hz "
        f"({_duty(rq.duty)} high)"
    ),
    pwm.PwmDutySet: lambda rq: f"set the duty of {_pin(rq.pin)} to {_duty(rq.duty)}",
    counter.CounterConfig: lambda rq: (
        f"make {_pin(rq.pin)} a counter of "
        f"{'rising' if rq.edge == Edge.RISING else 'falling'} edges"
    ),
    counter.CounterRead: lambda rq: f"read the count of {_pin(rq.pin)}",
    counter.CounterReset: lambda rq: f"reset the count of {_pin(rq.pin)}",
    counter.CounterWatch: lambda rq: (
        f"report the count of {_pin(rq.pin)} every {rq.every} counts"
        if rq.every
        else f"stop reporting the count of {_pin(rq.pin)}"
    ),
    encoder.EncoderConfig: lambda rq: (
        f"make {_pin(rq.pin_a)} (A) and {_pin(rq.pin_b)} (B) quadrature encoder "
        f"{rq.slot} (x{int(rq.mode)})"
    ),
    encoder.EncoderRead: lambda rq: f"read quadrature encoder {rq.slot}",
    i2c.I2CBlock: lambda rq: (
        f"free I2C stream block {rq.slot}"
        if not rq.length
        else f"read {rq.length} bytes at register 0x{rq.register:02X} of I2C device "
        f"0x{rq.address:02X} every stream period (block {rq.slot})"
    ),
    i2c.I2CBlockStatus: lambda rq: f"read the bus errors of I2C stream block {rq.slot}",
    encoder.EncoderPreset: lambda rq: (
        f"set the count of quadrature encoder {rq.slot} to {rq.value}"
    ),
    encoder.EncoderWatch: lambda rq: (
        f"report quadrature encoder {rq.slot} every {rq.every} counts"
        if rq.every
        else f"stop reporting quadrature encoder {rq.slot}"
    ),
    spi.SpiConfig: lambda rq: (
        f"take D11-D13 and {_pin(rq.cs)} (chip select) for SPI mode {rq.mode} "
        f"at {SpiClock(rq.clock).hz / 1e6:g} MHz"
    ),
    spi.SpiTransfer: lambda rq: f"exchange {_bytes(len(rq.data))} over SPI",
    pulse_in.PulseInConfig: lambda rq: (
        f"make {_pin(rq.pin)} pulse-width input {rq.slot} (signal lost after {rq.timeout_ms} ms)"
    ),
    pulse_in.PulseInRead: lambda rq: f"read pulse-width input {rq.slot}",
    sonar.SonarConfig: lambda rq: (
        f"make sonar {rq.slot} with its trigger on {_pin(rq.trigger)} and its echo on "
        f"{_pin(rq.echo)}"
    ),
    sonar.SonarRead: lambda rq: f"read sonar {rq.slot}",
    sonar.SonarTiming: lambda rq: (
        f"fire a sonar every {rq.period_ms} ms at {rq.speed_dm_s / 10:g} m/s"
    ),
    stream.StreamStart: _stream_start,
    stream.StreamStop: lambda rq: "stop the stream",
    failsafe.FailsafeArm: lambda rq: f"arm the failsafe ({rq.timeout_ms} ms)",
    failsafe.FailsafeSafeState: _safe_state,
    failsafe.FailsafeDisarm: lambda rq: "disarm the failsafe",
    stepper.StepperConfig: lambda rq: (
        f"make stepper {rq.index} step on {_pin(rq.step_pin)} with its direction on "
        f"{_pin(rq.dir_pin)}"
    ),
    stepper.StepperProfile: lambda rq: (
        f"give stepper {rq.index} a top speed of {rq.max_speed} steps/s and an "
        f"acceleration of {rq.acceleration} steps/s^2"
    ),
    stepper.StepperMove: lambda rq: (
        f"move stepper {rq.index} by {rq.steps} steps"
        if rq.relative
        else f"move stepper {rq.index} to position {rq.steps}"
    ),
    stepper.StepperRun: lambda rq: f"run stepper {rq.index} at {rq.speed} steps/s",
    stepper.StepperStop: lambda rq: (
        f"stop stepper {rq.index} {'at once' if rq.immediate else 'with deceleration'}"
    ),
    stepper.StepperRead: lambda rq: f"read stepper {rq.index}",
    stepper.StepperSetPosition: lambda rq: f"call stepper {rq.index}'s position {rq.position}",
    stepper.StepperLimit: lambda rq: (
        f"bind a {'positive' if rq.positive else 'negative'}-side limit switch on "
        f"{_pin(rq.pin)} (closed when {'high' if rq.active_high else 'low'}) to stepper {rq.index}"
        if rq.pin
        else f"remove stepper {rq.index}'s {'positive' if rq.positive else 'negative'}-side "
        "limit switch"
    ),
}


def describe(request: object) -> str:
    """``request`` in words; a request without an entry (a test's own) by its repr."""
    words = DESCRIPTIONS.get(type(request))  # type: ignore[arg-type]
    return words(request) if words is not None else repr(request)


set_request_words(describe)  # the error messages say requests with these words
