"""Firmware-timed sample streams (protocol extension).

The board samples from a timer interrupt and pushes one frame per sample; the transport
hands those frames to :class:`SampleStream`, which keeps them in a bounded buffer for the
consumer.  Nothing is lost silently:

* a sequence number that jumps counts the missing samples in :attr:`SampleStream.gaps`
  (the board skips a number when its transmit buffer had no room; the host loses frames
  to line noise);
* when the consumer falls behind and the buffer is full, the **oldest** sample is dropped
  (a controller wants the newest data) and counted in :attr:`SampleStream.dropped`;
* when the stream stops, the board's ``next_sequence`` reveals samples that were sent but
  never arrived.

A stream is one of the board's watches (:mod:`arduinoio_async.board.watches`): a reset
of the board forgets it, and restoring the board starts it again with the same layout
(the sequence numbers start at 0 again, counted in :attr:`SampleStream.restarts`, not as
a gap).  The board runs one stream: blocks asking for the same layout share it, another
layout is refused with :class:`UsageError` while it runs.
"""

from __future__ import annotations

import math
import time
from collections.abc import AsyncIterator, Sequence
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .. import protocol as p
from .._event_queue import SequencedQueue
from ..errors import LinkCapacityError, ValueRangeError
from ..protocol.pins import AnalogPin, DigitalPin, Function, require
from ..transport import Transport
from .sonars import SonarSample, sonar_block

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["DEFAULT_BUFFER", "Sample", "SampleStream", "run_stream", "stream_request"]

DEFAULT_BUFFER = 1000


@dataclass(frozen=True, slots=True)
class Sample:
    """One sample: when, which, and the values of what the stream asked for."""

    #: ``time.monotonic()`` when the frame was decoded on the host.
    host_time: float
    #: The board's microsecond timer at the sampling instant (wraps at 2**32).
    board_time_us: int
    sequence: int
    analog: dict[AnalogPin, int]
    #: Bit n = level of Dn (D2-D13), if the stream includes levels.
    levels: int | None = None
    #: Bit n = Dn rose / fell since the previous sample, if the stream includes edges.
    rose: int | None = None
    fell: int | None = None
    #: Counts of D2 and D3, if the stream includes counters.
    counters: tuple[int, int] | None = None
    #: Positions of the stepper slots 0-3 (0 for a slot without a stepper), if the stream
    #: includes steppers.
    steppers: tuple[int, ...] | None = None
    #: Signed count of each encoder slot (slot 0 first, a free slot 0), if the stream
    #: includes encoders.
    encoders: tuple[int, ...] | None = None
    #: Each sonar slot's latest reading (slot 0 first, the slots configured when the
    #: stream started), if the stream includes sonars.
    sonars: tuple[SonarSample, ...] | None = None
    #: The I2C blocks' bytes, one entry per block the stream reads (in the order given
    #: to ``board.stream(i2c=...)``), ``None`` where that period's read failed; ``None``
    #: if the stream reads no I2C blocks.
    i2c: tuple[bytes | None, ...] | None = None
    #: Per block: 0 if read, else the error code of the failed step (an
    #: :class:`~arduinoio_async.protocol.ErrorCode`: NACK, timeout).
    i2c_status: tuple[int, ...] | None = None
    #: The width in microseconds of the last pulse of each pulse input slot 0..n-1 (n: the
    #: highest slot with an input when the stream started, + 1; 0 where no pulse came yet),
    #: if the stream includes pulse inputs.
    pulse_widths: tuple[int, ...] | None = None
    #: Per slot: the signal is lost (or the slot has no input): its width is old.
    pulse_lost: tuple[bool, ...] | None = None

    def level(self, pin: DigitalPin) -> bool:
        """The level of ``pin`` in this sample; raises ValueError when the stream was
        started without ``levels=True``."""
        if self.levels is None:
            raise ValueError("this stream does not carry digital levels")
        return bool(self.levels >> int(pin) & 1)

    @classmethod
    def from_frame(cls, frame: p.StreamSample, host_time: float) -> Sample:
        """Decode a sample frame's payload (laid out as the stream was configured); the
        stream calls it, with the host's ``time.monotonic()`` at arrival."""
        data = frame.payload
        pos = 0

        def take(size: int) -> int:
            nonlocal pos
            value = int.from_bytes(data[pos : pos + size], "big")
            pos += size
            return value

        analog = {pin: take(2) for pin in AnalogPin if frame.analog_mask >> int(pin) & 1}
        levels = take(2) if frame.flags & p.StreamFlags.LEVELS else None
        rose = fell = None
        if frame.flags & p.StreamFlags.EDGES:
            rose, fell = take(2), take(2)
        counters = None
        if frame.flags & p.StreamFlags.COUNTERS:
            counters = (take(4), take(4))
        steppers = None
        if frame.flags & p.StreamFlags.STEPPERS:
            steppers = tuple((take(4) ^ 0x80000000) - 0x80000000 for _ in range(p.STEPPER_COUNT))
        encoders = None
        if frame.flags & p.StreamFlags.ENCODERS:
            encoders = tuple(
                ((take(4) + 2**31) & 0xFFFFFFFF) - 2**31 for _ in range(p.ENCODER_SLOTS)
            )
        sonars = None
        if frame.flags & p.StreamFlags.SONAR:
            sonars = sonar_block(data[pos:])
            pos += 1 + 3 * len(sonars)
        pulse_widths = pulse_lost = None
        if frame.flags & p.StreamFlags.PULSE_IN:
            slots = p.split_pulse_in_block(data[pos:])
            pos += 1 + 3 * len(slots)
            pulse_widths = tuple(width for width, _ in slots)
            pulse_lost = tuple(lost for _, lost in slots)
        i2c = i2c_status = None
        if frame.flags & p.StreamFlags.I2C:
            # free slots (length 0, status 0) are left out: the blocks come in slot order
            blocks = [b for b in p.split_i2c_blocks(data[pos:]) if b[1] or b[0]]
            i2c = tuple(None if status else value for status, value in blocks)
            i2c_status = tuple(status for status, _ in blocks)
        return cls(
            host_time,
            frame.timestamp_us,
            frame.sequence,
            analog,
            levels,
            rose,
            fell,
            counters,
            steppers,
            encoders,
            sonars=sonars,
            i2c=i2c,
            i2c_status=i2c_status,
            pulse_widths=pulse_widths,
            pulse_lost=pulse_lost,
        )


def stream_request(
    analog: Sequence[AnalogPin],
    levels: bool,
    edges: bool,
    counters: bool,
    period_ms: float,
    steppers: bool = False,
    encoders: bool = False,
    i2c_bytes: int | None = None,
    sonars: int | None = None,
    pulse_ins: int | None = None,
) -> p.StreamStart:
    """Validate a stream's parameters and build its START request (``i2c_bytes``: the
    data bytes of the I2C blocks it reads, None for none; ``sonars``: the sonar slots the
    block carries, None for no sonars; ``pulse_ins``: the pulse input slots it carries,
    None for no pulse inputs)."""
    mask = 0
    for pin in analog:
        require(pin, Function.ANALOG_INPUT)
        mask |= 1 << int(pin)
    flags = p.StreamFlags.NONE
    if levels:
        flags |= p.StreamFlags.LEVELS
    if edges:
        flags |= p.StreamFlags.EDGES
    if counters:
        flags |= p.StreamFlags.COUNTERS
    if steppers:
        flags |= p.StreamFlags.STEPPERS
    if encoders:
        flags |= p.StreamFlags.ENCODERS
    if pulse_ins is not None:
        flags |= p.StreamFlags.PULSE_IN
    if i2c_bytes is not None:
        flags |= p.StreamFlags.I2C
    if sonars is not None:
        flags |= p.StreamFlags.SONAR
    if not mask and not flags:
        raise ValueRangeError("stream content", "nothing", "at least one channel or flag")
    size = p.sample_payload_size(mask, flags, i2c_bytes or 0, sonars or 0, pulse_ins or 0)
    if size > p.STREAM_MAX_VALUES:
        raise ValueRangeError(
            "stream content",
            f"{size} value bytes",
            f"at most {p.STREAM_MAX_VALUES} a sample (steppers take {4 * p.STEPPER_COUNT}, "
            f"encoders {4 * p.ENCODER_SLOTS}, each analog channel 2, counters 8, edges 4, "
            f"levels 2, I2C blocks their bytes + {2 * p.I2C_BLOCK_SLOTS}, sonars 1 + 3 a slot, "
            "pulse inputs 1 + 3 a slot)",
        )
    finite = isinstance(period_ms, int | float) and math.isfinite(period_ms)
    period_us = round(period_ms * 1000) if finite else 0
    if (
        not finite
        or not p.STREAM_MIN_PERIOD_US <= period_us <= p.STREAM_MAX_PERIOD_US
        or period_us % p.STREAM_PERIOD_STEP_US
    ):
        raise ValueRangeError(
            "stream period (ms)",
            period_ms,
            f"{p.STREAM_MIN_PERIOD_US / 1000:g}-{p.STREAM_MAX_PERIOD_US / 1000:g} ms in steps "
            f"of {p.STREAM_PERIOD_STEP_US / 1000:g} ms",
        )
    return p.StreamStart(mask, flags, period_us)


class SampleStream(SequencedQueue[Sample]):
    """Async iterator over the samples of a running stream (see the module docstring)."""

    WHAT = "a stream"

    def __init__(self, link: Transport, request: p.StreamStart, buffer: int) -> None:
        self.request = request
        super().__init__(link, buffer)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.StreamSample):
            return
        sample = Sample.from_frame(event, time.monotonic())
        self._count_gap(sample.sequence)
        self._put(sample)

    def stopped(self, reply: p.Reply) -> None:
        """Account for samples sent before the stop but never received."""
        if not isinstance(reply, p.StreamStopReply):
            return
        if self._expected is not None:
            self.gaps += (reply.next_sequence - self._expected) & 0xFFFF
        elif reply.next_sequence:
            self.gaps += reply.next_sequence


def _describe(request: p.Request[Any]) -> str:
    if not isinstance(request, p.StreamStart):
        return str(request)
    channels = [f"A{n}" for n in range(p.ANALOG_CHANNELS) if request.analog_mask >> n & 1]
    return f"analog {', '.join(channels) or 'none'} every {request.period_us} us"


@asynccontextmanager
async def run_stream(
    board: BoardCore,
    request: p.StreamStart,
    buffer: int,
    setup: Sequence[p.Request[Any]] = (),
) -> AsyncIterator[SampleStream]:
    """Start ``request`` on ``board`` (after ``setup``: its I2C blocks, replayed with it
    after a reset), yield its samples, stop it when the block ends.

    The body of :meth:`Board.stream <arduinoio_async.board.Board.stream>`.  A period the
    link cannot carry comes back as :class:`LinkCapacityError` naming the shortest period
    at the board's baud rate; the stop (shielded from cancellation) accounts for samples
    never received.
    """
    samples = SampleStream(board.link, request, buffer)
    async with AsyncExitStack() as stack:
        try:
            await stack.enter_async_context(
                board.watches.subscribe(
                    ("stream",),
                    request,
                    p.StreamStop(),
                    samples,
                    setup=setup,
                    conflict=lambda held: (
                        f"{board} already streams {_describe(held)}: one stream per board "
                        "(end that block, or ask for the same layout to share it)"
                    ),
                )
            )
        except LinkCapacityError as exc:
            baud = board.capabilities.baud
            shortest = p.stream_min_period_us(request.analog_mask, request.flags, baud)
            raise LinkCapacityError(
                exc.code, exc.request, min_period_us=shortest, baud=baud
            ) from exc
        yield samples
