"""STREAM commands (class tag 0x07, extension) and samples, handled by ``firmware/src/stream.c``.

A timer interrupt samples analog channels, levels, edges and counters every
``period_us`` and pushes one StreamSample each; the board admits a stream only when its
frames leave a quarter of the link for command replies (:func:`stream_fits_link`).
"""

from __future__ import annotations

from typing import Annotated

from .._constants import (
    ENCODER_SLOTS,
    I2C_BLOCK_SLOTS,
    PULSE_IN_SLOTS,
    SONAR_SLOTS,
    STEPPER_COUNT,
    STREAM_FRAME_OVERHEAD,
    STREAM_LINK_SHARE_DEN,
    STREAM_LINK_SHARE_NUM,
    STREAM_MAX_VALUES,
    STREAM_MIN_PERIOD_US,
    STREAM_PERIOD_STEP_US,
    ClassTag,
    StreamFlags,
)
from .._layout import U8, U16, U32, Blob
from .._messages import Event, Reply, Request, echo, event_frame, reply_frame, request_frame

__all__ = [
    "StreamSample",
    "StreamStart",
    "StreamStartReply",
    "StreamStop",
    "StreamStopReply",
    "sample_payload_size",
    "split_i2c_blocks",
    "split_pulse_in_block",
    "split_sonar_block",
    "stream_fits_link",
    "stream_min_period_us",
]


@echo
class _Sampled:
    analog_mask: Annotated[int, U8]
    flags: Annotated[StreamFlags, U8]


@echo
class _Start(_Sampled):
    period_us: Annotated[int, U16]


@reply_frame(ClassTag.STREAM, 0x01)
class StreamStartReply(_Start, Reply): ...


# Not idempotent: a new start restarts the sequence numbers.
@request_frame(StreamStartReply, extension=True)
class StreamStart(_Start, Request[StreamStartReply]):
    """Sample from a timer interrupt every ``period_us`` and push one StreamSample each."""


@reply_frame(ClassTag.STREAM, 0x02)
class StreamStopReply(Reply):
    """``next_sequence``: the sequence number the next sample would have had."""

    next_sequence: Annotated[int, U16]


# Not idempotent: a repeat could hide a stream started in between.
@request_frame(StreamStopReply, extension=True)
class StreamStop(Request[StreamStopReply]):
    """Stop the stream; no sample frame follows this reply."""


@event_frame(0x01)
class StreamSample(_Sampled, Event):
    """One sample of a running stream; ``payload`` holds the values in the documented order.

    Order: one u16 per analog channel in ``analog_mask`` (lowest channel first), then if
    LEVELS: u16 levels of D0-D15 (bit n = Dn), if EDGES: u16 rose, u16 fell (latched since
    the previous sample), if COUNTERS: u32 count of D2, u32 count of D3, if STEPPERS: i32
    position of each stepper slot 0-3 (0 for a slot without a stepper), if ENCODERS: one
    i32 count per encoder slot (ENCODER_SLOTS, slot 0 first; a free slot reads 0), if
    SONAR: u8 count n, then per sonar slot 0..n-1 u16 distance in mm and u8 age in
    1.024 ms steps (:func:`split_sonar_block`), if PULSE_IN: u8 count n, then per pulse
    input slot 0..n-1 u16 width in us and u8 lost (:func:`split_pulse_in_block`), if I2C:
    per I2C block slot (I2C_BLOCK_SLOTS, slot 0 first) u8 length, u8 status and that many
    bytes (:func:`split_i2c_blocks`).
    """

    sequence: Annotated[int, U16]
    timestamp_us: Annotated[int, U32]
    payload: Annotated[bytes, Blob(STREAM_MAX_VALUES)]

    def __post_init__(self) -> None:
        fixed = sample_payload_size(
            self.analog_mask,
            self.flags & ~(StreamFlags.I2C | StreamFlags.SONAR | StreamFlags.PULSE_IN),
        )
        if self.flags & StreamFlags.SONAR:
            fixed += sonar_block_size(self.payload[fixed:])
        if self.flags & StreamFlags.PULSE_IN:
            fixed += pulse_in_block_size(self.payload[fixed:])
        if self.flags & StreamFlags.I2C:
            split_i2c_blocks(self.payload[fixed:])  # raises ValueError if malformed
        elif len(self.payload) != fixed:
            raise ValueError("stream sample payload does not match its mask and flags")


def sonar_block_size(data: bytes) -> int:
    """Bytes of the sonar block at the start of ``data`` (its first byte counts the sonars);
    ValueError if the count is impossible or the block is cut short."""
    if not data or data[0] > SONAR_SLOTS or len(data) < 1 + 3 * data[0]:
        raise ValueError("stream sample's sonar block is malformed or cut short")
    return 1 + 3 * data[0]


def split_sonar_block(data: bytes) -> list[tuple[int, int]]:
    """The sonar block at the start of ``data``: ``(distance_mm, age_ms)`` per sonar slot
    (slot 0 first; SONAR_NO_ECHO / SONAR_NO_READING as in SonarReadReply)."""
    size = sonar_block_size(data)
    return [
        (int.from_bytes(data[pos : pos + 2], "big"), data[pos + 2]) for pos in range(1, size, 3)
    ]


def pulse_in_block_size(data: bytes) -> int:
    """Bytes of the pulse input block at the start of ``data`` (its first byte counts the
    slots); ValueError if the count is impossible or the block is cut short."""
    if not data or data[0] > PULSE_IN_SLOTS or len(data) < 1 + 3 * data[0]:
        raise ValueError("stream sample's pulse input block is malformed or cut short")
    return 1 + 3 * data[0]


def split_pulse_in_block(data: bytes) -> list[tuple[int, bool]]:
    """The pulse input block at the start of ``data``: ``(width_us, lost)`` per slot
    (slot 0 first; a slot without an input reads lost)."""
    size = pulse_in_block_size(data)
    return [
        (int.from_bytes(data[pos : pos + 2], "big"), bool(data[pos + 2]))
        for pos in range(1, size, 3)
    ]


def split_i2c_blocks(data: bytes) -> list[tuple[int, bytes]]:
    """The I2C part of a sample: ``(status, bytes)`` per block slot (slot 0 first); the
    part is self-describing (each slot's length precedes it), so the host needs no copy of
    the blocks' configuration to decode it."""
    blocks: list[tuple[int, bytes]] = []
    pos = 0
    for _ in range(I2C_BLOCK_SLOTS):
        if pos + 2 > len(data):
            raise ValueError("stream sample's I2C blocks are cut short")
        length, status = data[pos], data[pos + 1]
        blocks.append((status, bytes(data[pos + 2 : pos + 2 + length])))
        pos += 2 + length
    if pos != len(data):
        raise ValueError("stream sample's I2C blocks do not match their lengths")
    return blocks


def sample_payload_size(
    analog_mask: int,
    flags: StreamFlags,
    i2c_bytes: int = 0,
    sonars: int = 0,
    pulse_ins: int = 0,
) -> int:
    """Bytes of values a sample with this channel mask and these flags carries
    (``i2c_bytes``: the configured I2C blocks' lengths added up, if the flags hold I2C;
    ``sonars``: the sonar slots the block carries, if the flags hold SONAR; ``pulse_ins``:
    the pulse input slots the block carries, if the flags hold PULSE_IN)."""
    size = 2 * (analog_mask & 0x3F).bit_count()
    if flags & StreamFlags.LEVELS:
        size += 2
    if flags & StreamFlags.EDGES:
        size += 4
    if flags & StreamFlags.COUNTERS:
        size += 8
    if flags & StreamFlags.STEPPERS:
        size += 4 * STEPPER_COUNT
    if flags & StreamFlags.ENCODERS:
        size += 4 * ENCODER_SLOTS
    if flags & StreamFlags.SONAR:
        size += 1 + 3 * sonars
    if flags & StreamFlags.PULSE_IN:
        size += 1 + 3 * pulse_ins
    if flags & StreamFlags.I2C:
        size += 2 * I2C_BLOCK_SLOTS + i2c_bytes
    return size


def stream_fits_link(frame_bytes: int, period_us: int, baud: int) -> bool:
    """The board's admission rule: the frames need at most 3/4 of the link's byte rate."""
    needed = frame_bytes * 10 * 1_000_000 * STREAM_LINK_SHARE_DEN
    return needed <= STREAM_LINK_SHARE_NUM * period_us * baud


def stream_min_period_us(
    analog_mask: int, flags: StreamFlags, baud: int, i2c_bytes: int = 0
) -> int:
    """Shortest period the board accepts for this sample layout at ``baud``."""
    frame_bytes = STREAM_FRAME_OVERHEAD + sample_payload_size(analog_mask, flags, i2c_bytes)
    period = STREAM_MIN_PERIOD_US
    while not stream_fits_link(frame_bytes, period, baud):
        period += STREAM_PERIOD_STEP_US
    return period
