"""The fake board: the real protocol core on a memory link, and a model of the board.

It decodes with ``Decoder.from_host()`` and encodes real reply frames, so a test never
keeps a second copy of the protocol; the model follows the firmware's checks in the
firmware's order (refusals included).  The digital and analog pins are modelled in
:mod:`._gpio`, the I2C bridge, pulse outputs and counters in :mod:`._peripherals`, the
timer-driven parts in :mod:`._timed`, and the board's end of the link (framing, filler,
faults) in :mod:`._fake_wire`.
"""

from __future__ import annotations

import contextlib
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import anyio
import anyio.abc

from .. import protocol as p
from ..protocol.boards import UNO_R3, BoardModel
from ..protocol.pins import Function
from ..protocol.timers import Timer
from ..transport import MemoryByteStream, memory_link
from ._fake_encoder import EncoderModels
from ._fake_i2c_blocks import I2CBlockModels
from ._fake_pulse_in import PulseInModels
from ._fake_sonar import SonarModels
from ._fake_spi import SpiModels
from ._fake_stepper import FakeSteppers
from ._fake_transaction import split_items
from ._fake_wire import FakeWire
from ._faults import Faults
from ._peripherals import (
    PinModel,
    check_pulse,
    has,
)
from ._timed import FailsafeModel, StreamModel

__all__ = ["FakeBoard"]

E = p.ErrorCode


_CHANGE_FRAME_BYTES = len(p.GpioChange(2, p.GpioState.FELL, 0, 0).encode())


@dataclass
class FakeBoard(I2CBlockModels, SpiModels, SonarModels, EncoderModels, PulseInModels, FakeWire):
    """A board model on an in-memory link; ``host_stream`` is the host's end."""

    board_id: int = 0x0001
    faults: Faults = field(default_factory=Faults)
    baud: int = p.DEFAULT_BAUD
    #: Levels the board sees on D0-D13 (outputs drive them; tests set inputs with drive()).
    levels: list[bool] = field(default_factory=lambda: [False] * 14)
    analog: list[int] = field(default_factory=lambda: [0] * 6)
    temperature_raw: int = 300
    #: Edges counted on D2 and D3 (only the edge each counter was configured for).
    counters: dict[int, int] = field(default_factory=lambda: {2: 0, 3: 0})
    pulses: dict[int, int] = field(default_factory=dict)
    #: Duty-cycle PWM pins: pin -> (frequency in Hz, duty 0-DUTY_FULL).
    duties: dict[int, tuple[int, int]] = field(default_factory=dict)
    #: 7-bit I2C address -> 256 registers.
    i2c_devices: dict[int, bytearray] = field(default_factory=lambda: {0x50: bytearray(256)})
    requests_seen: int = 0
    #: Replies whose bytes the faults changed (dropped, inserted, flipped, garbage).
    corrupted_replies: int = 0
    session: int = 0
    #: Low-latency mode (SetLowLatency): each reply is followed by filler bytes up to
    #: ``LOW_LATENCY_PAD`` (the firmware pads a burst; one reply is the common burst).
    low_latency: bool = False
    #: Filler bytes sent so far.
    filler_sent: int = 0
    #: GpioChange and CounterReport events dropped because the modelled transmit buffer
    #: was full.
    changes_dropped: int = 0
    #: The firmware has CRC-16 framing (Feature.CRC16, SetFraming); False models a board
    #: with older firmware, which answers SetFraming with UNKNOWN_DESCRIPTOR.
    crc_capable: bool = True
    #: The framing in force (XOR after every boot).
    framing: p.Framing = p.Framing.XOR
    #: The board model it describes (READ_BOARD_DESCRIPTION; protocol/boards.py).
    model: BoardModel = UNO_R3
    #: False models an image older than the description (no Feature.BOARD_DESCRIPTION:
    #: the library falls back to the Uno's Table III).
    describes: bool = True

    def __post_init__(self) -> None:
        self.host_stream, self._board_stream = memory_link()
        self.levels += [False] * (self.model.digital_pins - len(self.levels))
        self.analog += [0] * (self.model.analog_pins - len(self.analog))
        self._pins = {n: PinModel() for n in range(2, self.model.digital_pins)}
        #: The I2C bridge's speed, None while it is off (tests may switch it on directly).
        self.i2c_speed: p.I2CSpeed | None = None
        self._random = random.Random(self.faults.seed)
        self._decoder = p.Decoder.from_host(keep_invalid=True, framing=self.framing)
        self._task_group: anyio.abc.TaskGroup | None = None
        self._driven: set[int] = set()  # pins drive() set: a pull-up no longer decides them
        self._send_lock = anyio.Lock()  # whole frames only, as the firmware's TX ring
        #: The framing of the next reply, when not the one in force (RESET's reply).
        self._reply_framing: p.Framing | None = None
        self._booted = 0.0
        self.steppers = FakeSteppers(self)
        self.stream = StreamModel(positions=self.steppers.positions)
        self.failsafe = FailsafeModel()
        self.change_sequence = 0
        self.analog_sequence = 0
        #: AnalogWatch: channel -> [deadband, value reported last].
        self._analog_watches: dict[int, list[int]] = {}
        # The firmware sends change events from its interrupt into the transmit buffer,
        # dropping one that does not fit: a bounded queue models that buffer.
        self._changes_in, self._changes_out = anyio.create_memory_object_stream[p.Event](
            p.TX_BUFFER_SIZE // _CHANGE_FRAME_BYTES
        )
        self._handlers: dict[type[Any], Callable[[Any], p.Frame]] = {
            p.Reset: self._reset,
            p.ReadId: lambda r: p.ReadIdReply(self.board_id),
            p.ReadTemperature: lambda r: p.ReadTemperatureReply(self.temperature_raw),
            p.ReadCapabilities: self._capabilities,
            p.WriteId: self._write_id,
            p.ReadStatus: self._status,
            p.SetSession: self._set_session,
            p.SetLowLatency: self._set_low_latency,
            p.SetFraming: self._set_framing,
            p.ReadPinRoles: self._pin_roles,
            p.ReadBoardDescription: self._describe,
            p.GpioConfig: self._gpio_config,
            p.GpioRead: self._gpio_read,
            p.GpioWrite: self._gpio_write,
            p.GpioWatch: self._gpio_watch,
            p.PinRelease: self._release,
            p.AnalogRead: self._analog_read,
            p.AnalogReadAll: self._analog_read_all,
            p.AnalogWatch: self._analog_watch,
            p.I2CConfig: self._i2c_config,
            p.I2CRead: self._i2c_read,
            p.I2CWrite: self._i2c_write,
            p.PwmConfig: self._pwm,
            p.PwmSet: self._pwm,
            p.PwmDutyConfig: self._duty,
            p.PwmDutySet: self._duty,
            p.CounterConfig: self._counter_config,
            p.CounterRead: self._counter_read,
            p.CounterReset: self._counter_read,
            p.CounterWatch: self._counter_watch,
            **self._encoder_handlers(),
            **self._sonar_handlers(),
            **self._spi_handlers(),
            **self._pulse_in_handlers(),
            **self._i2c_block_handlers(),
            p.StreamStart: self._stream_start,
            p.StreamStop: lambda r: p.StreamStopReply(self.stream.stop()),
            p.FailsafeArm: self._failsafe_arm,
            p.FailsafeSafeState: self._failsafe_safe_state,
            p.FailsafeDisarm: self._failsafe_disarm,
            p.Transaction: self._transaction,
            **self.steppers.handlers(),
        }
        if not self.crc_capable:
            del self._handlers[p.SetFraming]

    async def __aenter__(self) -> FakeBoard:
        self._task_group = anyio.create_task_group()
        await self._task_group.__aenter__()
        self._booted = anyio.current_time()
        self._task_group.start_soon(self._serve, self._board_stream)
        self._task_group.start_soon(self._watchdog)
        self._task_group.start_soon(self._send_changes)
        self._task_group.start_soon(self.steppers.run)
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.unplug()
        if self._task_group is not None:
            self._task_group.cancel_scope.cancel()
            group, self._task_group = self._task_group, None
            await group.__aexit__(None, None, None)

    async def unplug(self) -> None:
        """Close the board's end, as a pulled cable: the host sees the port fail."""
        self.stream.stop()
        await self._board_stream.aclose()

    # ---- test controls -------------------------------------------------------------------

    def drive(self, pin: int, level: bool) -> None:
        """Drive an input pin from outside, latching edges like the pin-change interrupt."""
        self._driven.add(pin)
        if level != self.levels[pin]:
            state = self._pins[pin]
            state.rose |= level
            state.fell |= not level
            self.levels[pin] = level
            if level:
                self.stream.rose |= 1 << pin
            else:
                self.stream.fell |= 1 << pin
            if pin in self.counters and state.role == "counter":
                counted = level == (state.edge is p.Edge.RISING)
                self.counters[pin] += counted
                if counted and state.report_every:
                    self._report_count(pin, state)
            if state.watched and state.role == "input":
                self._report_change(pin, level)
            if state.role == "encoder":
                self._encoder_edge(pin)
            if state.role == "pulse-input":
                self._pulse_in_edge(pin, level)

    def set_analog(self, channel: int, value: int) -> None:
        """Move an analog input: a watched channel that moved past its deadband reports
        (the board finds the move at its next sample; the model at once).  Assigning
        ``analog[channel]`` directly moves it without reporting."""
        self.analog[channel] = value
        watch = self._analog_watches.get(channel)
        if watch is None or abs(value - watch[1]) <= watch[0]:
            return
        if self.i2c_speed is not None and channel in (4, 5):
            return  # the bus lines, not a voltage: silent while the bridge is on
        board_us = int((anyio.current_time() - self._booted) * 1_000_000) & 0xFFFFFFFF
        event = p.AnalogChange(channel, value, self.analog_sequence, board_us)
        self.analog_sequence = (self.analog_sequence + 1) & 0xFFFF
        try:
            self._changes_in.send_nowait(event)
            watch[1] = value  # a dropped event leaves the reference: the move reports again
        except anyio.WouldBlock:
            self.changes_dropped += 1

    def role(self, pin: int) -> str:
        """What the fake board set ``pin`` (D2 up to its model's last) up as: ``free``, ``input``,
        ``output``, ``pwm`` or ``counter``, for a test's assertions."""
        return self._pins[pin].role

    async def push(self, frame: p.Frame) -> None:
        """Send a board-initiated frame (a stream sample, a failsafe event) to the host."""
        async with self._send_lock:
            await self._board_stream.send(self._framed(frame.encode()))

    async def expire_failsafe(self) -> None:
        """Fire the armed failsafe now, as if the host had fallen silent for its timeout.

        For unit tests of what robot code does after a trip; without it the watchdog fires
        by itself once no request arrived for the armed timeout.
        """
        if not self.failsafe.armed:
            raise RuntimeError("the fake board's failsafe is not armed")
        await self._trip()

    # ---- serving ---------------------------------------------------------------------------

    async def _serve(self, stream: MemoryByteStream) -> None:
        try:
            await self._serve_requests(stream)
        except (anyio.BrokenResourceError, anyio.ClosedResourceError):
            return  # unplugged, or the host closed its end

    async def _serve_requests(self, stream: MemoryByteStream) -> None:
        discarding = False
        while True:
            if discarding:
                with anyio.move_on_after(p.INTER_BYTE_GAP_MS / 1000):
                    await stream.receive()
                    continue
                discarding = False
                self._decoder.reset()
            data = await stream.receive()
            for item in self._decoder.feed(data):
                if isinstance(item, p.InvalidValues):  # a frame, but values out of range
                    self.requests_seen += 1
                    self.failsafe.feed()
                    refusal = p.ErrorReply(item.class_tag, item.descriptor, E.VALUE_OUT_OF_RANGE)
                    await self._send(stream, refusal.encode())
                    continue
                if isinstance(item, p.Garbage):
                    error = p.ErrorReply(item.data[0] & 0x7F, 0, E.UNKNOWN_CLASS)
                    await self._send(stream, error.encode())
                    discarding = True
                    break
                self.requests_seen += 1
                self.failsafe.feed()  # every valid request feeds the watchdog, as on the board
                reply = self._answer(item)
                if self.faults.lose_reply and self._random.random() < self.faults.lose_reply:
                    continue
                await self._send(stream, reply.encode(), pad=True)

    def _answer(self, request: p.Frame) -> p.Frame:
        layout = request.LAYOUT
        handler = self._handlers.get(type(request))
        if handler is None:
            return p.ErrorReply(layout.class_tag, layout.descriptor, E.UNKNOWN_DESCRIPTOR)
        if self.failsafe.refuses(request):
            return self._error(request, E.FAILSAFE_TRIPPED)
        return handler(request)

    # ---- command models ----------------------------------------------------------------------

    def _reset(self, request: p.Reset) -> p.Frame:
        # the firmware sends the reply before it resets: in the framing in force
        self._reply_framing = self.framing
        self.reboot()
        return p.ResetReply()

    def reboot(self) -> None:
        """A fresh boot (watchdog, power loss, the reset button): RAM state is gone, the
        subscriptions and their sequence numbers with it; the EEPROM's ID stays."""
        self._pins = {n: PinModel() for n in range(2, self.model.digital_pins)}
        self.steppers.reset()
        self.counters = dict.fromkeys(self.counters, 0)
        self.encoders.clear()
        self.sonars.clear()
        self.pulse_inputs.clear()
        self.spi_config = None
        self.change_sequence = 0
        with contextlib.suppress(anyio.WouldBlock):
            while True:  # events still in the transmit buffer never leave it
                self._changes_out.receive_nowait()
        self.pulses.clear()
        self.duties.clear()
        self.i2c_speed = None
        self.session = 0
        self.low_latency = False
        self._set_decoder(p.Framing.XOR)
        self.stream.stop()
        self.stream.sequence = 0
        self._analog_watches.clear()
        self.analog_sequence = 0
        self.failsafe.disarm()
        self.failsafe.safe.clear()
        self._booted = anyio.current_time()

    def _status(self, request: p.ReadStatus) -> p.Frame:
        flags = self.failsafe.status()
        if self.stream.running:
            flags |= p.StatusFlags.STREAMING
        return p.ReadStatusReply(flags, self.session)

    def _capabilities(self, request: p.ReadCapabilities) -> p.Frame:
        features = 0
        for feature in p.Feature:
            features |= int(feature)
        if not self.crc_capable:
            features &= ~p.Feature.CRC16
        if not self.describes:
            features &= ~p.Feature.BOARD_DESCRIPTION
        return p.ReadCapabilitiesReply(
            p.PROTOCOL_VERSION, *p.FIRMWARE_VERSION, features, self.baud, p.RX_FIFO_SIZE
        )

    def _describe(self, request: p.ReadBoardDescription) -> p.Frame:
        if not self.describes:
            return self._error(request, p.ErrorCode.UNKNOWN_DESCRIPTOR)
        reply = self.model.reply(request.page)
        return reply or self._error(request, p.ErrorCode.VALUE_OUT_OF_RANGE)

    def _write_id(self, request: p.WriteId) -> p.Frame:
        self.board_id = request.board_id
        return p.WriteIdReply(request.board_id)

    def _set_decoder(self, framing: p.Framing) -> None:
        self.framing = framing
        self._decoder = p.Decoder.from_host(keep_invalid=True, framing=framing)

    def _set_framing(self, request: p.SetFraming) -> p.Frame:
        self._set_decoder(request.framing)  # the reply goes out in the new framing
        return p.SetFramingReply(request.framing)

    def _set_low_latency(self, request: p.SetLowLatency) -> p.Frame:
        self.low_latency = request.enabled
        return p.SetLowLatencyReply(request.enabled)

    def _set_session(self, request: p.SetSession) -> p.Frame:
        self.session = request.session
        return p.SetSessionReply(request.session)

    def _transaction(self, request: p.Transaction) -> p.Frame:
        """The firmware's order: check the whole list, then run the items one by one."""
        items = split_items(request.items)
        if items is None:
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        results = bytearray()
        for raw in items:
            layout = p.REQUEST_TYPES[(raw[0], raw[1])].LAYOUT
            try:
                item = layout.decode(raw + bytes((p.checksum(raw),)))
            except ValueError:
                reply: p.Frame = p.ErrorReply(raw[0], raw[1], E.VALUE_OUT_OF_RANGE)
            else:
                reply = self._answer(item)
            results += reply.encode()[:-1]
        return p.TransactionReply(request.seq, bytes(results))

    # ---- extensions: stream and failsafe ----------------------------------------------------

    def _stream_start(self, request: p.StreamStart) -> p.Frame:
        error = self.stream.check(
            request,
            self.baud,
            self.i2c_speed is not None,
            self.i2c_block_bytes(),
            max(self.sonars, default=-1) + 1,
        )
        if error is None and self._duty_timer_busy(Timer.TIMER0):
            error = E.PIN_BUSY  # duty PWM on D5/D6 holds the alarm timer
        if error is None and request.analog_mask and self._analog_watches:
            error = E.PIN_BUSY  # the ADC samples watched channels
        if error is not None:
            return self._error(request, error)
        self.stream.stop()
        self.stream.rose = self.stream.fell = 0  # the edges start afresh
        self.stream.request, self.stream.sequence, self.stream.running = request, 0, True
        self.stream.scope = anyio.CancelScope()
        if self._task_group is not None:
            self._task_group.start_soon(self._sample_forever, request, self.stream.scope)
        return p.StreamStartReply(request.analog_mask, request.flags, request.period_us)

    async def _sample_forever(self, request: p.StreamStart, scope: anyio.CancelScope) -> None:
        """One sample every period on the loop's clock; a late sample is skipped, not sent
        in a burst, so its sequence number is missing on the host as on a real board."""
        period = request.period_us / 1_000_000
        with scope:
            next_at = anyio.current_time() + period
            while True:
                await anyio.sleep(max(0.0, next_at - anyio.current_time()))
                late = int((anyio.current_time() - next_at) / period)
                self.stream.sequence = (self.stream.sequence + late) & 0xFFFF
                next_at += (late + 1) * period
                sample = self._sample(request)
                self.stream.sequence = (self.stream.sequence + 1) & 0xFFFF
                try:
                    await self._send(self._board_stream, sample.encode())
                except (anyio.BrokenResourceError, anyio.ClosedResourceError):
                    return

    def _sample(self, request: p.StreamStart) -> p.StreamSample:
        inputs = self._mask(Function.DIGITAL_INPUT)
        levels = sum(1 << n for n, high in enumerate(self.levels) if high and has(inputs, n))
        board_us = int((anyio.current_time() - self._booted) * 1_000_000)
        i2c = self.i2c_block_payload() if request.flags & p.StreamFlags.I2C else b""
        if request.flags & p.StreamFlags.SONAR:
            i2c = self.sonar_block() + i2c  # the sonar block comes before the I2C blocks
        return self.stream.sample(
            request, self.analog, levels, self.counters, board_us, self.encoder_counts(), i2c
        )

    def _failsafe_arm(self, request: p.FailsafeArm) -> p.Frame:
        error = self.failsafe.arm(request)
        return self._error(request, error) if error else p.FailsafeArmReply(request.timeout_ms)

    def _failsafe_safe_state(self, request: p.FailsafeSafeState) -> p.Frame:
        pin = request.pin
        error = self.failsafe.set_safe_state(
            request,
            digital=has(self._mask(Function.DIGITAL_OUTPUT), pin),
            pulse_capable=has(self._mask(Function.SOFT_PWM) | self._mask(Function.SERVO_PWM), pin),
            check_pulse=check_pulse,
            duty_capable=has(self._mask(Function.DUTY_PWM), pin),
        )
        if error is not None:
            return self._error(request, error)
        return p.FailsafeSafeStateReply(pin, request.kind, request.value)

    def _failsafe_disarm(self, request: p.FailsafeDisarm) -> p.Frame:
        self.failsafe.disarm()
        return p.FailsafeDisarmReply()

    async def _watchdog(self) -> None:
        failsafe = self.failsafe
        while True:
            left = failsafe.seconds_left()
            if left is not None and left <= 0:
                await self._trip()
                continue
            with anyio.move_on_after(left if left is not None else float("inf")):
                await failsafe.changed.wait()
            if failsafe.changed.is_set():
                failsafe.changed = anyio.Event()

    async def _trip(self) -> None:
        """Apply the safe states to the pins that still have the matching role, then report."""
        for pin, (kind, value) in self.failsafe.safe.items():
            role = self._pins[pin].role if pin in self._pins else "free"
            if kind is p.SafeKind.LEVEL and role == "output":
                self.levels[pin] = bool(value)
            elif kind is p.SafeKind.PULSE and role == "pwm":
                self.pulses[pin] = value
            elif kind is p.SafeKind.DUTY and role == "duty":
                self.duties[pin] = (self.duties[pin][0], value)
        self.steppers.stop_all()
        self.failsafe.armed, self.failsafe.tripped = False, True
        with contextlib.suppress(anyio.BrokenResourceError, anyio.ClosedResourceError):
            await self._send(self._board_stream, p.FailsafeTripped().encode())
