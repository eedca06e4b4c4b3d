"""An in-memory board for testing robot code (and this library) without hardware.

:class:`FakeBoard` answers requests with the real protocol core -- it decodes with
``Decoder.from_host()`` and encodes real reply frames -- over a :func:`memory_link`, and
models the board's state closely enough for unit tests: pin roles of Table III, levels,
latched edges, analog values, an I2C memory device, counters, servo pulses, the board ID,
status and session.  :class:`Faults` makes it an unreliable peer: replies split into
pieces, garbage, dropped, inserted and flipped bytes, lost and late replies, all from a
seeded random generator so a failing case can be replayed.

    async with FakeBoard(board_id=0x0001) as fake:
        async with Board.connect(fake.host_stream) as board:
            await board.gpio(D2).write(True)
            assert fake.levels[2]
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import anyio
import anyio.abc

from . import protocol as p
from .protocol.pins import Function, pin_mask
from .transport import MemoryByteStream, memory_link

__all__ = ["FakeBoard", "Faults"]

E = p.ErrorCode


@dataclass
class Faults:
    """What the fake board does wrong; probabilities are per reply or per byte."""

    seed: int = 0
    #: Send each reply in random pieces (down to single bytes).
    split: bool = False
    #: Probability that random garbage bytes precede a reply.
    garbage: float = 0.0
    #: Per-byte probabilities on the board-to-host direction.
    drop_byte: float = 0.0
    insert_byte: float = 0.0
    flip_byte: float = 0.0
    #: Probability that a request gets no reply at all.
    lose_reply: float = 0.0
    #: Each reply waits a random time in this range (seconds) before it is sent.
    delay: tuple[float, float] = (0.0, 0.0)


_DIGITAL = pin_mask(Function.DIGITAL_OUTPUT)
_SOFT_PWM = pin_mask(Function.SOFT_PWM)
_SERVO = pin_mask(Function.SERVO_PWM)
_COUNTER = pin_mask(Function.COUNTER)


def _has(mask: int, pin: int) -> bool:
    return 0 <= pin < 16 and bool(mask & (1 << pin))


@dataclass
class _Pin:
    role: str = "free"  # free | input | output | pwm | counter
    pull_up: bool = False
    rose: bool = False
    fell: bool = False


@dataclass
class FakeBoard:
    """A board model on an in-memory link; ``host_stream`` is the host's end."""

    board_id: int = 0x0001
    faults: Faults = field(default_factory=Faults)
    baud: int = p.DEFAULT_BAUD
    #: Levels the board sees on D0-D13 (outputs drive them; tests set inputs with drive()).
    levels: list[bool] = field(default_factory=lambda: [False] * 14)
    analog: list[int] = field(default_factory=lambda: [0] * 6)
    temperature_raw: int = 300
    counters: dict[int, int] = field(default_factory=lambda: {2: 0, 3: 0})
    pulses: dict[int, int] = field(default_factory=dict)
    #: 7-bit I2C address -> 256 registers.
    i2c_devices: dict[int, bytearray] = field(default_factory=lambda: {0x50: bytearray(256)})
    requests_seen: int = 0
    #: Replies whose bytes the faults changed (dropped, inserted, flipped, garbage).
    corrupted_replies: int = 0
    session: int = 0

    def __post_init__(self) -> None:
        self.host_stream, self._board_stream = memory_link()
        self._pins = {n: _Pin() for n in range(2, 14)}
        #: The I2C bridge's speed, None while it is off (tests may switch it on directly).
        self.i2c_speed: p.I2CSpeed | None = None
        self._random = random.Random(self.faults.seed)
        self._decoder = p.Decoder.from_host()
        self._task_group: anyio.abc.TaskGroup | None = None
        self._handlers: dict[type[Any], Callable[[Any], p.Frame]] = {
            p.Reset: self._reset,
            p.ReadId: lambda r: p.ReadIdReply(self.board_id),
            p.ReadTemperature: lambda r: p.ReadTemperatureReply(self.temperature_raw),
            p.ReadCapabilities: self._capabilities,
            p.WriteId: self._write_id,
            p.ReadStatus: lambda r: p.ReadStatusReply(p.StatusFlags.NONE, self.session),
            p.SetSession: self._set_session,
            p.ReadPinRoles: self._pin_roles,
            p.GpioConfig: self._gpio_config,
            p.GpioRead: self._gpio_read,
            p.GpioWrite: self._gpio_write,
            p.PinRelease: self._release,
            p.AnalogRead: self._analog_read,
            p.AnalogReadAll: lambda r: p.AnalogReadAllReply(tuple(self.analog)),
            p.I2CConfig: self._i2c_config,
            p.I2CRead: self._i2c_read,
            p.I2CWrite: self._i2c_write,
            p.PwmConfig: self._pwm,
            p.PwmSet: self._pwm,
            p.CounterConfig: self._counter_config,
            p.CounterRead: self._counter_read,
            p.CounterReset: self._counter_read,
        }

    async def __aenter__(self) -> FakeBoard:
        self._task_group = anyio.create_task_group()
        await self._task_group.__aenter__()
        self._task_group.start_soon(self._serve, self._board_stream)
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.unplug()
        if self._task_group is not None:
            self._task_group.cancel_scope.cancel()
            group, self._task_group = self._task_group, None
            await group.__aexit__(None, None, None)

    async def unplug(self) -> None:
        """Close the board's end, as a pulled cable: the host sees the port fail."""
        await self._board_stream.aclose()

    # ---- test controls -------------------------------------------------------------------

    def drive(self, pin: int, level: bool) -> None:
        """Drive an input pin from outside, latching edges like the pin-change interrupt."""
        if level != self.levels[pin]:
            state = self._pins[pin]
            state.rose |= level
            state.fell |= not level
            self.levels[pin] = level
            if pin in self.counters and state.role == "counter":
                self.counters[pin] += 1

    def role(self, pin: int) -> str:
        return self._pins[pin].role

    async def push(self, frame: p.Frame) -> None:
        """Send a board-initiated frame (a stream sample, a failsafe event) to the host."""
        await self._board_stream.send(frame.encode())

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
                if isinstance(item, p.Garbage):
                    error = p.ErrorReply(item.data[0] & 0x7F, 0, E.UNKNOWN_CLASS)
                    await self._send(stream, error.encode())
                    discarding = True
                    break
                self.requests_seen += 1
                reply = self._answer(item)
                if self.faults.lose_reply and self._random.random() < self.faults.lose_reply:
                    continue
                await self._send(stream, reply.encode())

    def _answer(self, request: p.Frame) -> p.Frame:
        layout = request.LAYOUT
        handler = self._handlers.get(type(request))
        if handler is None:
            return p.ErrorReply(layout.class_tag, layout.descriptor, E.UNKNOWN_DESCRIPTOR)
        return handler(request)

    async def _send(self, stream: MemoryByteStream, frame: bytes) -> None:
        faults, rnd = self.faults, self._random
        low, high = faults.delay
        if high > 0:
            await anyio.sleep(rnd.uniform(low, high))
        out = bytearray()
        if faults.garbage and rnd.random() < faults.garbage:
            out += bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 6)))
        for byte in frame:
            if faults.drop_byte and rnd.random() < faults.drop_byte:
                continue
            if faults.flip_byte and rnd.random() < faults.flip_byte:
                byte ^= 1 << rnd.randrange(8)
            out.append(byte)
            if faults.insert_byte and rnd.random() < faults.insert_byte:
                out.append(rnd.randrange(256))
        if bytes(out) != frame:
            self.corrupted_replies += 1
        if not faults.split:
            await stream.send(bytes(out))
            return
        while out:
            cut = rnd.randint(1, len(out))
            await stream.send(bytes(out[:cut]))
            del out[:cut]
            await anyio.lowlevel.checkpoint()

    # ---- command models ----------------------------------------------------------------------

    @staticmethod
    def _error(request: p.Frame, code: p.ErrorCode) -> p.ErrorReply:
        return p.ErrorReply(request.LAYOUT.class_tag, request.LAYOUT.descriptor, code)

    def _reset(self, request: p.Reset) -> p.Frame:
        self._pins = {n: _Pin() for n in range(2, 14)}
        self.pulses.clear()
        self.i2c_speed = None
        self.session = 0
        return p.ResetReply()

    def _capabilities(self, request: p.ReadCapabilities) -> p.Frame:
        features = 0
        for feature in p.Feature:
            features |= int(feature)
        return p.ReadCapabilitiesReply(
            p.PROTOCOL_VERSION, *p.FIRMWARE_VERSION, features, self.baud, p.RX_FIFO_SIZE
        )

    def _write_id(self, request: p.WriteId) -> p.Frame:
        self.board_id = request.board_id
        return p.WriteIdReply(request.board_id)

    def _pin_roles(self, request: p.ReadPinRoles) -> p.Frame:
        def mask(role: str) -> int:
            return sum(1 << n for n, pin in self._pins.items() if pin.role == role)

        return p.ReadPinRolesReply(mask("input"), mask("output"), mask("pwm"), mask("counter"))

    def _set_session(self, request: p.SetSession) -> p.Frame:
        self.session = request.session
        return p.SetSessionReply(request.session)

    def _gpio_config(self, request: p.GpioConfig) -> p.Frame:
        if not _has(_DIGITAL, request.pin):
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
        if output:
            self.levels[request.pin] = bool(flags & p.GpioFlags.INITIAL_HIGH)
        return p.GpioConfigReply(request.pin, request.flags)

    def _gpio_read(self, request: p.GpioRead) -> p.Frame:
        if not _has(_DIGITAL, request.pin):
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
        if not _has(_DIGITAL, request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self._pins[request.pin].role != "output":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        self.levels[request.pin] = request.value
        return p.GpioWriteReply(request.pin, request.value)

    def _release(self, request: p.PinRelease) -> p.Frame:
        if not _has(_DIGITAL, request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        self._pins[request.pin] = _Pin()
        self.pulses.pop(request.pin, None)
        return p.PinReleaseReply(request.pin)

    def _analog_read(self, request: p.AnalogRead) -> p.Frame:
        if request.channel >= p.ANALOG_CHANNELS:
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self.i2c_speed is not None and request.channel in (4, 5):
            return self._error(request, E.PIN_BUSY)
        return p.AnalogReadReply(request.channel, self.analog[request.channel])

    def _i2c_config(self, request: p.I2CConfig) -> p.Frame:
        self.i2c_speed = request.speed
        return p.I2CConfigReply(request.speed)

    def _i2c_device(self, request: p.I2CRead | p.I2CWrite) -> bytearray | p.ErrorReply:
        if self.i2c_speed is None:
            return self._error(request, E.I2C_NOT_CONFIGURED)
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
        soft = _has(_SOFT_PWM, pin)
        if not (soft or _has(_SERVO, pin)):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[pin]
        if isinstance(request, p.PwmConfig):
            if state.role not in ("free", "pwm"):
                return self._error(request, E.PIN_BUSY)
        elif state.role != "pwm":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        valid = pulse == 0 or p.PULSE_MIN_US <= pulse <= p.PULSE_MAX_US
        if not valid or (soft and pulse % p.SOFT_PWM_STEP_US):
            return self._error(request, E.VALUE_OUT_OF_RANGE)
        state.role = "pwm"
        self.pulses[pin] = pulse
        if isinstance(request, p.PwmConfig):
            return p.PwmConfigReply(pin, pulse)
        return p.PwmSetReply(pin, pulse)

    def _counter_config(self, request: p.CounterConfig) -> p.Frame:
        if not _has(_COUNTER, request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        state = self._pins[request.pin]
        if state.role not in ("free", "counter"):
            return self._error(request, E.PIN_BUSY)
        state.role = "counter"
        self.counters[request.pin] = 0
        return p.CounterConfigReply(request.pin, request.edge)

    def _counter_read(self, request: p.CounterRead | p.CounterReset) -> p.Frame:
        if not _has(_COUNTER, request.pin):
            return self._error(request, E.PIN_NOT_CAPABLE)
        if self._pins[request.pin].role != "counter":
            return self._error(request, E.PIN_NOT_CONFIGURED)
        count = self.counters[request.pin]
        if isinstance(request, p.CounterReset):
            self.counters[request.pin] = 0
            return p.CounterResetReply(request.pin, count)
        return p.CounterReadReply(request.pin, count)
