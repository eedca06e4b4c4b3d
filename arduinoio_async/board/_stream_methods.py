"""The board's stream method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: it turns the caller's choice of channels, flags and
I2C blocks into one STREAM START (:func:`~.streaming.stream_request`), checks the firmware
image holds every class it names and that no duty PWM holds the timer the samples need,
sets up the I2C blocks, then runs the stream (:mod:`arduinoio_async.board.streaming`).
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import UsageError
from ..protocol.pins import AnalogPin, Function
from ._features import require_stream_features
from .i2c_blocks import I2CBlock, block_requests, blocks_bytes
from .motors import check_stream
from .pulse_inputs import pulse_input_slots
from .sonars import Sonar
from .streaming import DEFAULT_BUFFER, SampleStream, run_stream, stream_request

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["StreamMethods"]


def sonar_slots(board: BoardCore) -> int:
    """The sonar slots a stream started now carries: the highest live sonar's slot + 1
    (as the board counts them at STREAM START)."""
    slots = [
        claim.handle.slot
        for claim in board.roles.values()
        if isinstance(claim.handle, Sonar) and not claim.handle.released
    ]
    return max(slots, default=-1) + 1


class StreamMethods:
    """``board.stream()``: samples taken by the board's timer."""

    @asynccontextmanager
    async def stream(
        self,
        *,
        analog: Sequence[AnalogPin] = (),
        levels: bool = False,
        edges: bool = False,
        counters: bool = False,
        period_ms: float = 10.0,
        buffer: int = DEFAULT_BUFFER,
        steppers: bool = False,
        encoders: bool = False,
        i2c: Sequence[I2CBlock] = (),
        sonars: bool = False,
        pulse_inputs: bool = False,
    ) -> AsyncIterator[SampleStream]:
        """Samples taken by the board's timer every ``period_ms`` (0.25 ms and up).

        ``async with board.stream(analog=[A0, A1], period_ms=1) as samples:
        async for s in samples: ...``.  Commands keep working meanwhile.  A period the
        link cannot carry is refused by the board with :class:`LinkCapacityError`;
        ``steppers=True`` carries every stepper slot's position (``Sample.steppers``); see
        :mod:`arduinoio_async.board.streaming` for gaps and the overflow policy.
        ``i2c=[I2CBlock(0x68, 0x3B, 14)]`` adds register blocks the board reads each
        period (:mod:`arduinoio_async.board.i2c_blocks`; set up the bus first).
        ``sonars=True`` carries the latest reading of each sonar slot up to the highest
        one set up now (``Sample.sonars``; set the sonars up first).
        ``pulse_inputs=True`` carries the pulse inputs' last widths and lost flags
        (``Sample.pulse_widths``, ``Sample.pulse_lost``; set the inputs up first: the
        samples carry the slots up to the highest one in use when the stream starts).
        """
        board = cast("BoardCore", self)
        for pin in analog:
            board.model.require(pin, Function.ANALOG_INPUT)
        blocks = block_requests(i2c) if i2c else []
        i2c_bytes = blocks_bytes(i2c) if i2c else None
        pulse_ins = pulse_input_slots(board) if pulse_inputs else None
        request = stream_request(
            analog,
            levels,
            edges,
            counters,
            period_ms,
            steppers,
            encoders,
            i2c_bytes,
            sonar_slots(board) if sonars else None,
            pulse_ins,
        )
        require_stream_features(board, p.StreamFlags(request.flags))
        check_stream(board)  # duty PWM on D5/D6 holds the timer the samples need
        if blocks and board.roles.i2c is None:
            raise UsageError("I2C blocks in the stream need the bus: await board.i2c() first")
        async with run_stream(board, request, buffer, setup=blocks) as samples:
            yield samples
