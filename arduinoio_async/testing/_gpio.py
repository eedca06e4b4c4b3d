"""The fake board's digital and analog pins: set-ups, reads, writes, watches, releases.

The checks follow the firmware's (``gpio.c``, ``analog.c``) in its order, refusals
included; a watched pin or channel reports a change into the modelled transmit buffer,
dropping the event (and counting it) when the buffer is full, as the board does.
"""

from __future__ import annotations

import anyio
from anyio.streams.memory import MemoryObjectSendStream

from .. import protocol as p
from ..protocol.pins import Function
from ._fake_stepper import FakeSteppers
from ._peripherals import PeripheralModels, PinModel, has
from ._timed import StreamModel

__all__ = ["GpioModels"]

E = p.ErrorCode


class GpioModels(PeripheralModels):
    """Digital and analog pins (mixed into the FakeBoard, after the peripherals)."""

    levels: list[bool]
    analog: list[int]
    stream: StreamModel
    steppers: FakeSteppers
    change_sequence: int
    changes_dropped: int
    _driven: set[int]
    _booted: float
    _analog_watches: dict[int, list[int]]
    _changes_in: MemoryObjectSendStream[p.Event]

    def _gpio_config(self, request: p.GpioConfig) -> p.Frame:
        if not has(self._mask(Function.DIGITAL_OUTPUT), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        pin = self._pins[request.pin]
        if pin.role not in ("free", "input", "output"):
            return self._error(request, E.PIN_BUSY)
        flags = request.flags
        output = bool(flags & p.GpioFlags.OUTPUT)
        if flags & ~0x07 or (output and flags & p.GpioFlags.PULL_UP):
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        if not output and flags & p.GpioFlags.INITIAL_HIGH:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        pin.role = "output" if output else "input"
        pin.pull_up = bool(flags & p.GpioFlags.PULL_UP)
        pin.rose = pin.fell = False
        pin.watched = False  # a new configuration ends a subscription
        if output:
            self.levels[request.pin] = bool(flags & p.GpioFlags.INITIAL_HIGH)
        elif pin.pull_up and request.pin not in self._driven:
            self.levels[request.pin] = True  # nothing attached: the pull-up wins
        return p.GpioConfigReply(request.pin, request.flags)

    def _gpio_read(self, request: p.GpioRead) -> p.Frame:
        if not has(self._mask(Function.DIGITAL_OUTPUT), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        pin = self._pins[request.pin]
        if pin.role not in ("input", "output"):
            return self._error(request, E.PIN_NOT_CONFIGURED)
        state = p.GpioState.HIGH if self.levels[request.pin] else p.GpioState.LOW
        if pin.role == "input":
            state |= (p.GpioState.ROSE if pin.rose else 0) | (p.GpioState.FELL if pin.fell else 0)
            pin.rose = pin.fell = False
        return p.GpioReadReply(request.pin, state)

    def _gpio_write(self, request: p.GpioWrite) -> p.Frame:
        if not has(self._mask(Function.DIGITAL_OUTPUT), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self._pins[request.pin].role != "output":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        self.levels[request.pin] = request.value
        return p.GpioWriteReply(request.pin, request.value)

    def _gpio_watch(self, request: p.GpioWatch) -> p.Frame:
        if not has(self._mask(Function.DIGITAL_OUTPUT), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        pin = self._pins[request.pin]
        if pin.role != "input":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        pin.watched = request.enable
        return p.GpioWatchReply(request.pin, request.enable)

    def _release(self, request: p.PinRelease) -> p.Frame:
        if not has(self._mask(Function.DIGITAL_OUTPUT), request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self._pins[request.pin].role == "stepper":
            self.steppers.release(request.pin)
        self._pins[request.pin] = PinModel()
        self.pulses.pop(request.pin, None)
        self.duties.pop(request.pin, None)
        return p.PinReleaseReply(request.pin)

    def _analog_refusal(self, channel: int) -> p.ErrorCode | None:
        """Why the model refuses analog ``channel``: not an input, or an I2C pin while the
        bus is on (A4/A5 on an Uno); None when it may be read."""
        number = self.model.digital_pins + channel
        if number not in self.model.pin_numbers(Function.ANALOG_INPUT):
            return E.PIN_NOT_CAPABLE
        if self.i2c_speed is not None and number in self.model.pin_numbers(Function.I2C):
            return E.PIN_BUSY
        return None

    def _analog_read_all(self, request: p.AnalogReadAll) -> p.Frame:
        return p.AnalogReadAllReply(tuple(self.analog[: p.ANALOG_CHANNELS]))

    def _analog_read(self, request: p.AnalogRead) -> p.Frame:
        refusal = self._analog_refusal(request.channel)
        if refusal is not None:
            return self._error(request, refusal)
        return p.AnalogReadReply(request.channel, self.analog[request.channel])

    def _analog_watch(self, request: p.AnalogWatch) -> p.Frame:
        channel, deadband = request.channel, request.deadband
        refusal = self._analog_refusal(channel) if channel < p.ANALOG_CHANNELS else None
        if channel >= p.ANALOG_CHANNELS or refusal is not None:  # watches: 6 channels
            return self._error(request, refusal or E.PIN_NOT_CAPABLE)
        if deadband > p.ANALOG_MAX:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        stream = self.stream.request
        if deadband and self.stream.running and stream is not None and stream.analog_mask:
            return self._error(request, E.PIN_BUSY)  # the stream's ADC chain owns the ADC
        if deadband:
            self._analog_watches[channel] = [deadband, self.analog[channel]]
        else:
            self._analog_watches.pop(channel, None)
        return p.AnalogWatchReply(channel, deadband, self.analog[channel])

    def _report_change(self, pin: int, level: bool) -> None:
        edge = p.GpioState.HIGH | p.GpioState.ROSE if level else p.GpioState.FELL
        board_us = int((anyio.current_time() - self._booted) * 1_000_000) & 0xFFFFFFFF
        event = p.GpioChange(pin, edge, self.change_sequence, board_us)
        self.change_sequence = (self.change_sequence + 1) & 0xFFFF
        try:
            self._changes_in.send_nowait(event)
        except anyio.WouldBlock:
            self.changes_dropped += 1  # its sequence number is used up, as on the board

    def _report_count(self, pin: int, state: PinModel) -> None:
        state.since_report += 1
        if state.since_report < state.report_every:
            return
        state.since_report = 0
        board_us = int((anyio.current_time() - self._booted) * 1_000_000) & 0xFFFFFFFF
        report = p.CounterReport(pin, self.counters[pin] & 0xFFFFFFFF, board_us)
        try:
            self._changes_in.send_nowait(report)
        except anyio.WouldBlock:
            self.changes_dropped += 1

    def _pin_roles(self, request: p.ReadPinRoles) -> p.Frame:
        def mask(role: str) -> int:  # the reply's u16 masks hold D0-D15 (a Mega's others: none)
            return sum(1 << n for n, pin in self._pins.items() if pin.role == role and n < 16)

        pwm = mask("pwm") | mask("duty")  # duty-cycle PWM is reported as PWM
        roles = (mask("input"), mask("output"), pwm, mask("counter"))
        return p.ReadPinRolesReply(*roles, mask("pulse-input"))
