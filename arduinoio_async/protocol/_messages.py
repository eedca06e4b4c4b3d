"""The command table: every request, its reply, error replies and board-initiated events.

Each message is a frozen dataclass whose annotations are its wire layout (see
``_layout``).  A request names its reply type as its generic parameter, so
``await transport.request(ReadId())`` is typed as returning ``ReadIdReply``.  A reply
*matches* its request when it has the expected type and repeats every field the two have in
common (tags, pin, channel, address...): that is how a client proves a reply belongs to the
request it is waiting for.

Descriptor tags of the paper are kept; rows marked *extension* go beyond the paper.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Annotated, Any, ClassVar, Generic, TypeVar

from ._constants import (
    ERROR_FLAG,
    FRAMING_ERRORS,
    MAX_BLOB,
    STREAM_FRAME_OVERHEAD,
    STREAM_LINK_SHARE_DEN,
    STREAM_LINK_SHARE_NUM,
    STREAM_MIN_PERIOD_US,
    STREAM_PERIOD_STEP_US,
    TEMP_MV_AT_25C,
    TEMP_MV_PER_C,
    TEMP_REFERENCE_MV,
    ClassTag,
    Edge,
    ErrorCode,
    GpioFlags,
    GpioState,
    I2CSpeed,
    SafeKind,
    StatusFlags,
    StreamFlags,
)
from ._layout import U8, U16, U32, Array, Blob, Frame, frame

__all__ = [
    "EVENT_TYPES",
    "IDEMPOTENT_WRITES",
    "READ_ONLY_REQUESTS",
    "REPLY_TYPES",
    "REQUEST_TYPES",
    "AnalogRead",
    "AnalogReadAll",
    "AnalogReadAllReply",
    "AnalogReadReply",
    "CounterConfig",
    "CounterConfigReply",
    "CounterRead",
    "CounterReadReply",
    "CounterReport",
    "CounterReset",
    "CounterResetReply",
    "CounterWatch",
    "CounterWatchReply",
    "ErrorReply",
    "Event",
    "FailsafeArm",
    "FailsafeArmReply",
    "FailsafeDisarm",
    "FailsafeDisarmReply",
    "FailsafeSafeState",
    "FailsafeSafeStateReply",
    "FailsafeTripped",
    "GpioChange",
    "GpioConfig",
    "GpioConfigReply",
    "GpioRead",
    "GpioReadReply",
    "GpioWatch",
    "GpioWatchReply",
    "GpioWrite",
    "GpioWriteReply",
    "I2CConfig",
    "I2CConfigReply",
    "I2CRead",
    "I2CReadReply",
    "I2CWrite",
    "I2CWriteReply",
    "PinRelease",
    "PinReleaseReply",
    "PwmConfig",
    "PwmConfigReply",
    "PwmSet",
    "PwmSetReply",
    "ReadCapabilities",
    "ReadCapabilitiesReply",
    "ReadId",
    "ReadIdReply",
    "ReadPinRoles",
    "ReadPinRolesReply",
    "ReadStatus",
    "ReadStatusReply",
    "ReadTemperature",
    "ReadTemperatureReply",
    "Reply",
    "Request",
    "Reset",
    "ResetReply",
    "SetSession",
    "SetSessionReply",
    "StreamSample",
    "StreamStart",
    "StreamStartReply",
    "StreamStop",
    "StreamStopReply",
    "Transaction",
    "TransactionReply",
    "WriteId",
    "WriteIdReply",
    "sample_payload_size",
    "stream_fits_link",
    "stream_min_period_us",
]


class Reply(Frame):
    """A success reply of the board."""

    __slots__ = ()


class Event(Frame):
    """A frame the board sends without a request (extension, class tag 0x40)."""

    __slots__ = ()


R_co = TypeVar("R_co", bound=Reply, covariant=True)


class Request(Frame, Generic[R_co]):
    """A host request whose success reply has type ``R_co``."""

    __slots__ = ()
    REPLY: ClassVar[type[Reply]]
    #: Field names the reply must repeat; computed when the request is registered.
    ECHO: ClassVar[tuple[str, ...]]
    #: Extension beyond the paper.
    EXTENSION: ClassVar[bool] = False
    #: Sending it twice has the effect of sending it once, so a request whose reply was
    #: lost may be sent again (docs/protocol.md, "Idempotency and retries").
    IDEMPOTENT: ClassVar[bool] = False
    #: It changes nothing on the board (implies IDEMPOTENT).
    READS_ONLY: ClassVar[bool] = False

    def matches(self, reply: Reply) -> bool:
        """True when ``reply`` is this request's reply and echoes what identifies it."""
        if type(reply) is not self.REPLY:
            return False
        return all(getattr(self, name) == getattr(reply, name) for name in self.ECHO)


REQUEST_TYPES: dict[tuple[int, int], type[Request[Reply]]] = {}
REPLY_TYPES: dict[tuple[int, int], type[Reply]] = {}
EVENT_TYPES: dict[tuple[int, int], type[Event]] = {}

Q = TypeVar("Q", bound=type[Request[Any]])
P = TypeVar("P", bound=type[Reply])
E = TypeVar("E", bound=type[Event])


def _reply(class_tag: ClassTag, descriptor: int) -> Callable[[P], P]:
    def register(cls: P) -> P:
        frame(class_tag, descriptor)(cls)
        REPLY_TYPES[(class_tag, descriptor)] = cls
        return cls

    return register


def _event(descriptor: int) -> Callable[[E], E]:
    def register(cls: E) -> E:
        frame(ClassTag.EVENT, descriptor)(cls)
        EVENT_TYPES[(ClassTag.EVENT, descriptor)] = cls
        return cls

    return register


def _request(reply: type[Reply], *, extension: bool = False) -> Callable[[Q], Q]:
    """Register a request under its reply's tags; the echo is the fields both share."""

    def register(cls: Q) -> Q:
        layout = reply.LAYOUT
        frame(layout.class_tag, layout.descriptor)(cls)
        cls.REPLY = reply
        reply_names = {f.name for f in fields(reply)}  # type: ignore[arg-type]
        cls.ECHO = tuple(f.name for f in fields(cls) if f.name in reply_names)  # type: ignore[arg-type]
        cls.EXTENSION = extension
        REQUEST_TYPES[(layout.class_tag, layout.descriptor)] = cls
        return cls

    return register


def _check_10_bit(value: int) -> None:
    """Replies are validated where the range is known: it catches corrupt frames that an
    8-bit XOR checksum lets through (one in 256)."""
    if not 0 <= value <= 0x3FF:
        raise ValueError(f"{value} is not a 10-bit ADC value")


# ---- MISC (0x01) --------------------------------------------------------------------------


@_reply(ClassTag.MISC, 0x01)
@dataclass(frozen=True, slots=True)
class ResetReply(Reply):
    """Sent before the watchdog resets the board."""


@_request(ResetReply)
@dataclass(frozen=True, slots=True)
class Reset(Request[ResetReply]):
    """Hardware reset: the board answers, then restarts through its watchdog."""


@_reply(ClassTag.MISC, 0x02)
@dataclass(frozen=True, slots=True)
class ReadIdReply(Reply):
    """The paper's Table II: ``01 02 IDH IDL CS``."""

    board_id: Annotated[int, U16]


@_request(ReadIdReply)
@dataclass(frozen=True, slots=True)
class ReadId(Request[ReadIdReply]):
    """The paper's Table I: ``01 02 03``."""


@_reply(ClassTag.MISC, 0x03)
@dataclass(frozen=True, slots=True)
class ReadTemperatureReply(Reply):
    """Raw 10-bit ADC reading of the chip's sensor against the internal 1.1 V reference."""

    raw: Annotated[int, U16]

    def __post_init__(self) -> None:
        _check_10_bit(self.raw)

    @property
    def millivolts(self) -> float:
        return self.raw * TEMP_REFERENCE_MV / 1024

    @property
    def celsius(self) -> float:
        """Datasheet-typical conversion; calibrate per chip for better than +/-10 C."""
        return 25.0 + (self.millivolts - TEMP_MV_AT_25C) / TEMP_MV_PER_C


@_request(ReadTemperatureReply)
@dataclass(frozen=True, slots=True)
class ReadTemperature(Request[ReadTemperatureReply]):
    """Read the chip temperature sensor (ADC channel 8)."""


@_reply(ClassTag.MISC, 0x04)
@dataclass(frozen=True, slots=True)
class ReadCapabilitiesReply(Reply):
    """What the firmware is and can do; ``baud`` is the rate it was built for."""

    protocol_version: Annotated[int, U8]
    firmware_major: Annotated[int, U8]
    firmware_minor: Annotated[int, U8]
    features: Annotated[int, U16]
    baud: Annotated[int, U32]
    rx_buffer: Annotated[int, U8]


@_request(ReadCapabilitiesReply, extension=True)
@dataclass(frozen=True, slots=True)
class ReadCapabilities(Request[ReadCapabilitiesReply]):
    """Protocol and firmware version, feature bits, build baud rate, receive FIFO size."""


@_reply(ClassTag.MISC, 0x05)
@dataclass(frozen=True, slots=True)
class WriteIdReply(Reply):
    """Sent after the ID has been written to EEPROM and read back."""

    board_id: Annotated[int, U16]


@_request(WriteIdReply, extension=True)
@dataclass(frozen=True, slots=True)
class WriteId(Request[WriteIdReply]):
    """Store a new 16-bit board ID in EEPROM."""

    board_id: Annotated[int, U16]


@_reply(ClassTag.MISC, 0x06)
@dataclass(frozen=True, slots=True)
class ReadStatusReply(Reply):
    """Failsafe and stream state, and the session tag (0 after every boot)."""

    flags: Annotated[StatusFlags, U8]
    session: Annotated[int, U16]


@_request(ReadStatusReply, extension=True)
@dataclass(frozen=True, slots=True)
class ReadStatus(Request[ReadStatusReply]):
    """Cheap heartbeat; a session tag of 0 tells the host the board has rebooted."""


@_reply(ClassTag.MISC, 0x07)
@dataclass(frozen=True, slots=True)
class SetSessionReply(Reply):
    session: Annotated[int, U16]


@_request(SetSessionReply, extension=True)
@dataclass(frozen=True, slots=True)
class SetSession(Request[SetSessionReply]):
    """Tag this boot of the board so the host can detect a reset by itself later."""

    session: Annotated[int, U16]


@_reply(ClassTag.MISC, 0x08)
@dataclass(frozen=True, slots=True)
class ReadPinRolesReply(Reply):
    """Bit n of each mask is set when Dn has that role on the board (D0/D1 carry the UART).

    Roles last until released or reset, also across host programs, so a bench tool asks
    the board instead of guessing why it refuses a pin.
    """

    gpio_input: Annotated[int, U16]
    gpio_output: Annotated[int, U16]
    pwm: Annotated[int, U16]
    counter: Annotated[int, U16]


@_request(ReadPinRolesReply, extension=True)
@dataclass(frozen=True, slots=True)
class ReadPinRoles(Request[ReadPinRolesReply]):
    """Which digital pins are GPIO inputs, GPIO outputs, PWM (servo or software) or counters."""


@_reply(ClassTag.MISC, 0x09)
@dataclass(frozen=True, slots=True)
class TransactionReply(Reply):
    """Every item's reply frame (or error reply) without its checksum, in item order."""

    results: Annotated[bytes, Blob(MAX_BLOB)]


@_request(TransactionReply, extension=True)
@dataclass(frozen=True, slots=True)
class Transaction(Request[TransactionReply]):
    """Several requests run back to back on the board, one reply with every result.

    ``items`` holds the request frames without their checksums (docs/protocol.md 7.5);
    build it with :func:`~arduinoio_async.protocol.pack_items`.
    """

    items: Annotated[bytes, Blob(MAX_BLOB)]


# ---- GPIO (0x02) --------------------------------------------------------------------------


@_reply(ClassTag.GPIO, 0x01)
@dataclass(frozen=True, slots=True)
class GpioConfigReply(Reply):
    pin: Annotated[int, U8]
    flags: Annotated[GpioFlags, U8]


@_request(GpioConfigReply)
@dataclass(frozen=True, slots=True)
class GpioConfig(Request[GpioConfigReply]):
    """Make a pin a digital input (optional pull-up) or output (initial level)."""

    pin: Annotated[int, U8]
    flags: Annotated[GpioFlags, U8]


@_reply(ClassTag.GPIO, 0x02)
@dataclass(frozen=True, slots=True)
class GpioReadReply(Reply):
    pin: Annotated[int, U8]
    state: Annotated[GpioState, U8]

    def __post_init__(self) -> None:
        if self.state & ~0x07:
            raise ValueError(f"GPIO state {int(self.state):#04x} has undefined bits")

    @property
    def level(self) -> bool:
        return bool(self.state & GpioState.HIGH)

    @property
    def rose(self) -> bool:
        return bool(self.state & GpioState.ROSE)

    @property
    def fell(self) -> bool:
        return bool(self.state & GpioState.FELL)


@_request(GpioReadReply)
@dataclass(frozen=True, slots=True)
class GpioRead(Request[GpioReadReply]):
    """Read the level and the edges latched since the previous read (then cleared)."""

    pin: Annotated[int, U8]


@_reply(ClassTag.GPIO, 0x03)
@dataclass(frozen=True, slots=True)
class GpioWriteReply(Reply):
    pin: Annotated[int, U8]
    value: Annotated[bool, U8]


@_request(GpioWriteReply)
@dataclass(frozen=True, slots=True)
class GpioWrite(Request[GpioWriteReply]):
    """Set a digital output."""

    pin: Annotated[int, U8]
    value: Annotated[bool, U8]


@_reply(ClassTag.GPIO, 0x04)
@dataclass(frozen=True, slots=True)
class PinReleaseReply(Reply):
    pin: Annotated[int, U8]


@_request(PinReleaseReply, extension=True)
@dataclass(frozen=True, slots=True)
class PinRelease(Request[PinReleaseReply]):
    """Free a digital pin from any role (GPIO, PWM, counter): it becomes a plain input."""

    pin: Annotated[int, U8]


@_reply(ClassTag.GPIO, 0x05)
@dataclass(frozen=True, slots=True)
class GpioWatchReply(Reply):
    pin: Annotated[int, U8]
    enable: Annotated[bool, U8]


@_request(GpioWatchReply, extension=True)
@dataclass(frozen=True, slots=True)
class GpioWatch(Request[GpioWatchReply]):
    """Report every change of a GPIO input as a GpioChange event (``enable`` 1) or stop.

    The pin must be a GPIO input; the subscription ends with ``enable`` 0, a new
    configuration of the pin, its release or a reset.
    """

    pin: Annotated[int, U8]
    enable: Annotated[bool, U8]


# ---- ANALOG (0x03) ------------------------------------------------------------------------


@_reply(ClassTag.ANALOG, 0x02)
@dataclass(frozen=True, slots=True)
class AnalogReadReply(Reply):
    channel: Annotated[int, U8]
    value: Annotated[int, U16]

    def __post_init__(self) -> None:
        _check_10_bit(self.value)


@_request(AnalogReadReply)
@dataclass(frozen=True, slots=True)
class AnalogRead(Request[AnalogReadReply]):
    """One 10-bit conversion of channel 0-5 against AVCC."""

    channel: Annotated[int, U8]


@_reply(ClassTag.ANALOG, 0x03)
@dataclass(frozen=True, slots=True)
class AnalogReadAllReply(Reply):
    values: Annotated[tuple[int, ...], Array(U16, 6)]

    def __post_init__(self) -> None:
        for value in self.values:
            _check_10_bit(value)


@_request(AnalogReadAllReply)
@dataclass(frozen=True, slots=True)
class AnalogReadAll(Request[AnalogReadAllReply]):
    """All six channels, A0 first."""


# ---- I2C (0x04) ---------------------------------------------------------------------------


@_reply(ClassTag.I2C, 0x01)
@dataclass(frozen=True, slots=True)
class I2CConfigReply(Reply):
    speed: Annotated[I2CSpeed, U8]


@_request(I2CConfigReply)
@dataclass(frozen=True, slots=True)
class I2CConfig(Request[I2CConfigReply]):
    """Enable the I2C master on A4/A5 at 100 or 400 kHz."""

    speed: Annotated[I2CSpeed, U8]


@_reply(ClassTag.I2C, 0x02)
@dataclass(frozen=True, slots=True)
class I2CReadReply(Reply):
    address: Annotated[int, U8]
    register: Annotated[int, U8]
    data: Annotated[bytes, Blob(MAX_BLOB)]


@_request(I2CReadReply)
@dataclass(frozen=True, slots=True)
class I2CRead(Request[I2CReadReply]):
    """Write the register offset, repeated start, read ``length`` bytes (7-bit address)."""

    address: Annotated[int, U8]
    register: Annotated[int, U8]
    length: Annotated[int, U8]

    def matches(self, reply: Reply) -> bool:
        return (
            Request.matches(self, reply)
            and isinstance(reply, I2CReadReply)
            and len(reply.data) == self.length
        )


@_reply(ClassTag.I2C, 0x03)
@dataclass(frozen=True, slots=True)
class I2CWriteReply(Reply):
    address: Annotated[int, U8]
    register: Annotated[int, U8]
    length: Annotated[int, U8]


@_request(I2CWriteReply)
@dataclass(frozen=True, slots=True)
class I2CWrite(Request[I2CWriteReply]):
    """Write the register offset followed by ``data`` (7-bit address)."""

    address: Annotated[int, U8]
    register: Annotated[int, U8]
    data: Annotated[bytes, Blob(MAX_BLOB)]

    def matches(self, reply: Reply) -> bool:
        return (
            Request.matches(self, reply)
            and isinstance(reply, I2CWriteReply)
            and reply.length == len(self.data)
        )


# ---- PWM (0x05) ---------------------------------------------------------------------------


@_reply(ClassTag.PWM, 0x01)
@dataclass(frozen=True, slots=True)
class PwmConfigReply(Reply):
    pin: Annotated[int, U8]
    pulse_us: Annotated[int, U16]


@_request(PwmConfigReply)
@dataclass(frozen=True, slots=True)
class PwmConfig(Request[PwmConfigReply]):
    """Attach a servo output: hardware PWM on D9/D10, software PWM on D2-D7.

    ``pulse_us`` 0 attaches without pulses (line held low); otherwise 1000-2000, in steps
    of SOFT_PWM_STEP_US on software PWM pins.
    """

    pin: Annotated[int, U8]
    pulse_us: Annotated[int, U16]


@_reply(ClassTag.PWM, 0x02)
@dataclass(frozen=True, slots=True)
class PwmSetReply(Reply):
    pin: Annotated[int, U8]
    pulse_us: Annotated[int, U16]


@_request(PwmSetReply)
@dataclass(frozen=True, slots=True)
class PwmSet(Request[PwmSetReply]):
    """Set the pulse width of an attached servo output (0 stops the pulses)."""

    pin: Annotated[int, U8]
    pulse_us: Annotated[int, U16]


# ---- COUNTER (0x06) -----------------------------------------------------------------------


@_reply(ClassTag.COUNTER, 0x01)
@dataclass(frozen=True, slots=True)
class CounterConfigReply(Reply):
    pin: Annotated[int, U8]
    edge: Annotated[Edge, U8]


@_request(CounterConfigReply)
@dataclass(frozen=True, slots=True)
class CounterConfig(Request[CounterConfigReply]):
    """Count edges on D2 (INT0) or D3 (INT1); the count starts at zero."""

    pin: Annotated[int, U8]
    edge: Annotated[Edge, U8]


@_reply(ClassTag.COUNTER, 0x02)
@dataclass(frozen=True, slots=True)
class CounterReadReply(Reply):
    pin: Annotated[int, U8]
    count: Annotated[int, U32]


@_request(CounterReadReply)
@dataclass(frozen=True, slots=True)
class CounterRead(Request[CounterReadReply]):
    """Read a counter (32 bit, wrapping)."""

    pin: Annotated[int, U8]


@_reply(ClassTag.COUNTER, 0x03)
@dataclass(frozen=True, slots=True)
class CounterResetReply(Reply):
    pin: Annotated[int, U8]
    count: Annotated[int, U32]


@_request(CounterResetReply, extension=True)
@dataclass(frozen=True, slots=True)
class CounterReset(Request[CounterResetReply]):
    """Read and clear a counter in one step, so no event falls between the two."""

    pin: Annotated[int, U8]


@_reply(ClassTag.COUNTER, 0x04)
@dataclass(frozen=True, slots=True)
class CounterWatchReply(Reply):
    pin: Annotated[int, U8]
    every: Annotated[int, U16]


@_request(CounterWatchReply, extension=True)
@dataclass(frozen=True, slots=True)
class CounterWatch(Request[CounterWatchReply]):
    """Send a CounterReport every ``every`` counts (0 stops); ends with a new CONFIG."""

    pin: Annotated[int, U8]
    every: Annotated[int, U16]


# ---- STREAM (0x07, extension) ---------------------------------------------------------------


@_reply(ClassTag.STREAM, 0x01)
@dataclass(frozen=True, slots=True)
class StreamStartReply(Reply):
    analog_mask: Annotated[int, U8]
    flags: Annotated[StreamFlags, U8]
    period_us: Annotated[int, U16]


@_request(StreamStartReply, extension=True)
@dataclass(frozen=True, slots=True)
class StreamStart(Request[StreamStartReply]):
    """Sample from a timer interrupt every ``period_us`` and push one StreamSample each."""

    analog_mask: Annotated[int, U8]
    flags: Annotated[StreamFlags, U8]
    period_us: Annotated[int, U16]


@_reply(ClassTag.STREAM, 0x02)
@dataclass(frozen=True, slots=True)
class StreamStopReply(Reply):
    """``next_sequence``: the sequence number the next sample would have had."""

    next_sequence: Annotated[int, U16]


@_request(StreamStopReply, extension=True)
@dataclass(frozen=True, slots=True)
class StreamStop(Request[StreamStopReply]):
    """Stop the stream; no sample frame follows this reply."""


# ---- FAILSAFE (0x08, extension) -------------------------------------------------------------


@_reply(ClassTag.FAILSAFE, 0x01)
@dataclass(frozen=True, slots=True)
class FailsafeArmReply(Reply):
    timeout_ms: Annotated[int, U16]


@_request(FailsafeArmReply, extension=True)
@dataclass(frozen=True, slots=True)
class FailsafeArm(Request[FailsafeArmReply]):
    """Arm the link watchdog; clears a tripped state.  Every valid request feeds it."""

    timeout_ms: Annotated[int, U16]


@_reply(ClassTag.FAILSAFE, 0x02)
@dataclass(frozen=True, slots=True)
class FailsafeSafeStateReply(Reply):
    pin: Annotated[int, U8]
    kind: Annotated[SafeKind, U8]
    value: Annotated[int, U16]


@_request(FailsafeSafeStateReply, extension=True)
@dataclass(frozen=True, slots=True)
class FailsafeSafeState(Request[FailsafeSafeStateReply]):
    """What a pin does when the watchdog fires: a level (0/1) or a pulse width (0 = none)."""

    pin: Annotated[int, U8]
    kind: Annotated[SafeKind, U8]
    value: Annotated[int, U16]


@_reply(ClassTag.FAILSAFE, 0x03)
@dataclass(frozen=True, slots=True)
class FailsafeDisarmReply(Reply):
    """The watchdog is off."""


@_request(FailsafeDisarmReply, extension=True)
@dataclass(frozen=True, slots=True)
class FailsafeDisarm(Request[FailsafeDisarmReply]):
    """Turn the link watchdog off."""


# ---- board-initiated events (0x40, extension) ------------------------------------------------


@_event(0x01)
@dataclass(frozen=True, slots=True)
class StreamSample(Event):
    """One sample of a running stream; ``payload`` holds the values in the documented order.

    Order: one u16 per analog channel in ``analog_mask`` (lowest channel first), then if
    LEVELS: u16 levels of D0-D15 (bit n = Dn), if EDGES: u16 rose, u16 fell (latched since
    the previous sample), if COUNTERS: u32 count of D2, u32 count of D3.
    """

    analog_mask: Annotated[int, U8]
    flags: Annotated[StreamFlags, U8]
    sequence: Annotated[int, U16]
    timestamp_us: Annotated[int, U32]
    payload: Annotated[bytes, Blob(MAX_BLOB)]

    def __post_init__(self) -> None:
        if len(self.payload) != sample_payload_size(self.analog_mask, self.flags):
            raise ValueError("stream sample payload does not match its mask and flags")


def sample_payload_size(analog_mask: int, flags: StreamFlags) -> int:
    """Bytes of values a sample with this channel mask and these flags carries."""
    size = 2 * (analog_mask & 0x3F).bit_count()
    if flags & StreamFlags.LEVELS:
        size += 2
    if flags & StreamFlags.EDGES:
        size += 4
    if flags & StreamFlags.COUNTERS:
        size += 8
    return size


def stream_fits_link(frame_bytes: int, period_us: int, baud: int) -> bool:
    """The board's admission rule: the frames need at most 3/4 of the link's byte rate."""
    needed = frame_bytes * 10 * 1_000_000 * STREAM_LINK_SHARE_DEN
    return needed <= STREAM_LINK_SHARE_NUM * period_us * baud


def stream_min_period_us(analog_mask: int, flags: StreamFlags, baud: int) -> int:
    """Shortest period the board accepts for this sample layout at ``baud``."""
    frame_bytes = STREAM_FRAME_OVERHEAD + sample_payload_size(analog_mask, flags)
    period = STREAM_MIN_PERIOD_US
    while not stream_fits_link(frame_bytes, period, baud):
        period += STREAM_PERIOD_STEP_US
    return period


@_event(0x02)
@dataclass(frozen=True, slots=True)
class FailsafeTripped(Event):
    """The link watchdog fired and applied the safe states."""


@_event(0x03)
@dataclass(frozen=True, slots=True)
class GpioChange(Event):
    """A watched input changed, seen by its pin-change interrupt (docs/protocol.md 7.4).

    ``state`` is the level now and the edge that led to it (ROSE or FELL);
    ``sequence`` counts every change event the board produced, sent or not (a full
    transmit buffer drops one), so the host sees a loss as a gap; ``timestamp_us`` is
    the board's clock when the interrupt ran.
    """

    pin: Annotated[int, U8]
    state: Annotated[GpioState, U8]
    sequence: Annotated[int, U16]
    timestamp_us: Annotated[int, U32]

    def __post_init__(self) -> None:
        if self.state not in (GpioState.HIGH | GpioState.ROSE, GpioState.FELL):
            raise ValueError(f"GPIO change state {int(self.state):#04x} is not an edge")

    @property
    def level(self) -> bool:
        return bool(self.state & GpioState.HIGH)


@_event(0x04)
@dataclass(frozen=True, slots=True)
class CounterReport(Event):
    """A watched counter reached another ``every`` counts (docs/protocol.md 7.4).

    ``count`` is the count when the interrupt ran; a report the transmit buffer had no
    room for is dropped, which the next report's count shows.
    """

    pin: Annotated[int, U8]
    count: Annotated[int, U32]
    timestamp_us: Annotated[int, U32]


# ---- error replies ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ErrorReply(Frame):
    """``CT|0x80 DT code CS``: the board refused the request with tags ``CT``/``DT``.

    For bytes the board could not attribute to any request (an unknown class tag) ``DT``
    is 0 and ``class_tag`` is the offending byte without its high bit.
    """

    class_tag: int
    descriptor: int
    code: ErrorCode

    SIZE: ClassVar[int] = 4

    def encode(self) -> bytes:
        body = bytes((ERROR_FLAG | self.class_tag, self.descriptor, self.code))
        return body + bytes((body[0] ^ body[1] ^ body[2],))

    def answers(self, request: Request[Any]) -> bool:
        """True when this error names the tags of ``request``."""
        layout = request.LAYOUT
        return self.class_tag == layout.class_tag and self.descriptor == layout.descriptor

    @property
    def framing(self) -> bool:
        """The board lost the frame boundaries and discards input until the line is quiet."""
        return self.code in FRAMING_ERRORS


# ---- idempotency (docs/protocol.md, "Idempotency and retries") --------------------------------

#: Requests that only read.  Not here: GpioRead (clears the latched edges), CounterReset.
READ_ONLY_REQUESTS: tuple[type[Request[Any]], ...] = (
    ReadId,
    ReadTemperature,
    ReadCapabilities,
    ReadStatus,
    AnalogRead,
    AnalogReadAll,
    I2CRead,
    CounterRead,
)
#: Requests that set a state: a repeat sets the same state again.  Not here: Reset,
#: WriteId (EEPROM wear, and the board answers with its new ID), I2CWrite (a device may
#: count or queue writes), CounterConfig (restarts the count), StreamStart (restarts the
#: sequence), StreamStop and FailsafeArm (a repeat can hide what happened in between).
IDEMPOTENT_WRITES: tuple[type[Request[Any]], ...] = (
    SetSession,
    GpioConfig,
    GpioWrite,
    GpioWatch,
    PinRelease,
    I2CConfig,
    PwmConfig,
    PwmSet,
    FailsafeSafeState,
    FailsafeDisarm,
    CounterWatch,
)
for _cls in READ_ONLY_REQUESTS:
    _cls.READS_ONLY = True
    _cls.IDEMPOTENT = True
for _cls in IDEMPOTENT_WRITES:
    _cls.IDEMPOTENT = True
