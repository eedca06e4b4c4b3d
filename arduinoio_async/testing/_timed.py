"""The fake board's timer-driven features: the sample stream and the link failsafe.

Both follow the firmware (``firmware/src/stream.c``, ``failsafe.c``) rule for rule, so a
robot program unit-tested against :class:`~arduinoio_async.testing.FakeBoard` meets the
same refusals, sequence numbers and safe states as on a real board.  Time is the event
loop's clock: a sample that could not be taken on time (a blocked loop) is skipped with
its sequence number, as the firmware skips a sample whose predecessor is still converting,
so the host sees a gap instead of a burst.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import anyio

from .. import protocol as p

__all__ = ["FailsafeModel", "StreamModel"]

E = p.ErrorCode


@dataclass
class StreamModel:
    """A running stream's parameters and its next sequence number."""

    running: bool = False
    request: p.StreamStart | None = None
    sequence: int = 0
    #: Edges latched for the stream since its previous sample (bit n = Dn).
    rose: int = 0
    fell: int = 0
    #: Cancels the sampling task of the running stream.
    scope: anyio.CancelScope | None = None
    #: The stepper slots' positions (StreamFlags.STEPPERS), set by the board.
    positions: Callable[[], Sequence[int]] = lambda: [0] * p.STEPPER_COUNT

    def check(
        self,
        request: p.StreamStart,
        baud: int,
        i2c_on: bool,
        i2c_bytes: int = 0,
        sonars: int = 0,
    ) -> p.ErrorCode | None:
        """The firmware's checks of a START request, in its order."""
        mask, flags, period = request.analog_mask, int(request.flags), request.period_us
        all_flags = int(
            p.StreamFlags.LEVELS
            | p.StreamFlags.EDGES
            | p.StreamFlags.COUNTERS
            | p.StreamFlags.STEPPERS
            | p.StreamFlags.ENCODERS
            | p.StreamFlags.SONAR
            | p.StreamFlags.I2C
        )
        if (
            mask & ~((1 << p.ANALOG_CHANNELS) - 1)
            or flags & ~all_flags
            or (mask == 0 and flags == 0)
            or not p.STREAM_MIN_PERIOD_US <= period <= p.STREAM_MAX_PERIOD_US
            or period % p.STREAM_PERIOD_STEP_US
            or p.sample_payload_size(mask, request.flags, i2c_bytes, sonars) > p.STREAM_MAX_VALUES
        ):
            return E.VALUE_OUT_OF_RANGE
        if i2c_on and mask & 0x30:  # A4/A5 carry SDA/SCL while the bridge is on
            return E.PIN_BUSY
        if flags & p.StreamFlags.I2C and not i2c_on:
            return E.I2C_NOT_CONFIGURED
        size = p.sample_payload_size(mask, request.flags, i2c_bytes, sonars)
        if not p.stream_fits_link(p.STREAM_FRAME_OVERHEAD + size, period, baud):
            return E.LINK_CAPACITY
        return None

    def sample(
        self,
        request: p.StreamStart,
        analog: Sequence[int],
        levels: int,
        counters: Mapping[int, int],
        board_us: int,
        encoders: Sequence[int] = (),
        i2c: bytes = b"",
    ) -> p.StreamSample:
        """The next sample frame, its values in the documented order (see StreamSample);
        taking it clears the stream's latched edges, as the firmware's sample does."""
        mask = request.analog_mask
        values = [analog[ch] for ch in range(p.ANALOG_CHANNELS) if mask >> ch & 1]
        payload = struct.pack(f">{len(values)}H", *values)
        if request.flags & p.StreamFlags.LEVELS:
            payload += struct.pack(">H", levels)
        if request.flags & p.StreamFlags.EDGES:
            payload += struct.pack(">HH", self.rose, self.fell)
            self.rose = self.fell = 0
        if request.flags & p.StreamFlags.COUNTERS:
            payload += struct.pack(">II", counters[2], counters[3])
        if request.flags & p.StreamFlags.STEPPERS:
            payload += struct.pack(f">{p.STEPPER_COUNT}i", *self.positions())
        if request.flags & p.StreamFlags.ENCODERS:
            counts = tuple(encoders) + (0,) * (p.ENCODER_SLOTS - len(encoders))
            payload += struct.pack(f">{p.ENCODER_SLOTS}i", *counts)
        payload += i2c  # the sonar block and the I2C blocks' part, if any
        return p.StreamSample(mask, request.flags, self.sequence, board_us & 0xFFFFFFFF, payload)

    def stop(self) -> int:
        """Stop sampling; returns the sequence number the next sample would have had."""
        self.running = False
        if self.scope is not None:
            self.scope.cancel()
            self.scope = None
        return self.sequence


@dataclass
class FailsafeModel:
    """The link watchdog: armed by the host, fed by every request, fired by silence."""

    armed: bool = False
    tripped: bool = False
    timeout_ms: int = 0
    last_feed: float = 0.0
    #: pin -> (kind, value) applied when the watchdog fires.
    safe: dict[int, tuple[p.SafeKind, int]] = field(default_factory=dict)
    #: Set when arming changes the deadline, so the watchdog task re-reads it.
    changed: anyio.Event = field(default_factory=anyio.Event)

    def refuses(self, request: p.Frame) -> bool:
        """The firmware refuses requests that change an output while tripped (``dispatch.c``)."""
        if not self.tripped:
            return False
        tag = request.LAYOUT.class_tag
        if tag == p.ClassTag.GPIO:
            return not isinstance(request, p.GpioRead | p.GpioWatch)
        if tag == p.ClassTag.STEPPER:
            return isinstance(request, p.StepperMove | p.StepperRun)
        return tag == p.ClassTag.PWM

    def feed(self) -> None:
        if self.armed:
            self.last_feed = anyio.current_time()

    def status(self) -> p.StatusFlags:
        flags = p.StatusFlags.NONE
        if self.armed:
            flags |= p.StatusFlags.FAILSAFE_ARMED
        if self.tripped:
            flags |= p.StatusFlags.FAILSAFE_TRIPPED
        return flags

    def arm(self, request: p.FailsafeArm) -> p.ErrorCode | None:
        if not p.FAILSAFE_MIN_TIMEOUT_MS <= request.timeout_ms <= p.FAILSAFE_MAX_TIMEOUT_MS:
            return E.VALUE_OUT_OF_RANGE
        self.timeout_ms = request.timeout_ms
        self.last_feed = anyio.current_time()
        self.tripped = False
        self.armed = True
        self.changed.set()
        return None

    def set_safe_state(
        self,
        request: p.FailsafeSafeState,
        digital: bool,
        pulse_capable: bool,
        check_pulse: Callable[[int, int], p.ErrorCode | None],
        duty_capable: bool = False,
    ) -> p.ErrorCode | None:
        """The firmware's checks of a SAFE_STATE request, in its order."""
        if not digital:
            return E.PIN_NOT_CAPABLE
        kind = int(request.kind)
        if kind > p.SafeKind.DUTY or (kind == p.SafeKind.LEVEL and request.value > 1):
            return E.VALUE_OUT_OF_RANGE
        if kind == p.SafeKind.PULSE:
            if not pulse_capable:
                return E.PIN_NOT_CAPABLE
            error = check_pulse(request.pin, request.value)
            if error is not None:
                return error
        if kind == p.SafeKind.DUTY and not duty_capable:
            return E.PIN_NOT_CAPABLE
        self.safe[request.pin] = (p.SafeKind(kind), request.value)
        return None

    def disarm(self) -> None:
        self.armed = self.tripped = False
        self.changed.set()

    def seconds_left(self) -> float | None:
        """Time until the watchdog fires if nothing feeds it; None while it is not armed."""
        if not self.armed:
            return None
        return self.last_feed + self.timeout_ms / 1000 - anyio.current_time()
