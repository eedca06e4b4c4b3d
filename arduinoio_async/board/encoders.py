"""Quadrature encoders: the :class:`Encoder` handle, its states and reports.

``enc = await board.encoder(a=D2, b=D3, mode="x4")`` decodes an encoder on the board: every
edge of A and B is counted in an interrupt (INT0/INT1 on D2/D3, pin-change interrupts on
the other pins), so no count is lost however slowly the host reads, and a skipped state
(the encoder outran the board, or a glitch) is counted as an *invalid transition* instead
of silently losing or inventing steps (:mod:`arduinoio_async.protocol.commands.encoder`).

Velocity comes from edge timing: each :class:`EncoderState` carries the board time of the
last edge that changed the count, so :meth:`EncoderState.velocity_since` divides whole
counts by the exact time between their edges; no error comes from when the host asked.
Counts are also in the firmware-timed stream (``board.stream(encoders=True)``) and, with
:meth:`Encoder.reports`, pushed by the board every N counts.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin
from .changes import DEFAULT_CHANGE_BUFFER, IntervalReports
from .handles import PinHandle

if TYPE_CHECKING:
    from ..transport import Transport
    from ._core import BoardCore

__all__ = ["MODES", "Encoder", "EncoderReports", "EncoderState", "ModeName", "encoder_mode"]

ModeName = Literal["x1", "x2", "x4"]
#: The decoding modes by name: counts per cycle of A and B.
MODES: dict[str, p.EncoderMode] = {
    "x1": p.EncoderMode.X1,
    "x2": p.EncoderMode.X2,
    "x4": p.EncoderMode.X4,
}


def encoder_mode(mode: str | int | p.EncoderMode) -> p.EncoderMode:
    """``"x4"``, ``4`` or ``EncoderMode.X4`` -> ``EncoderMode.X4``; anything else is refused."""
    if isinstance(mode, str) and mode.lower() in MODES:
        return MODES[mode.lower()]
    if isinstance(mode, int) and not isinstance(mode, bool) and mode in (1, 2, 4):
        return p.EncoderMode(mode)
    raise ValueRangeError("encoder mode", mode, '"x1", "x2" or "x4"')


@dataclass(frozen=True, slots=True)
class EncoderState:
    """An encoder's count, its invalid transitions and the time of its last counting edge."""

    #: Signed 32-bit count in the mode's units (wraps at +-2**31).
    count: int
    #: Skipped states since set-up or the last preset (16 bit, wrapping).
    invalid: int
    #: Board microseconds of the last edge that changed the count (0: none yet).
    edge_us: int

    def velocity_since(self, earlier: EncoderState) -> float:
        """Counts per second between two states, timed by their last edges.

        0.0 when no edge came in between (the encoder stands still, or too slowly to
        tell); the board clock wraps after 71 minutes, which the subtraction absorbs.
        """
        elapsed = (self.edge_us - earlier.edge_us) & 0xFFFFFFFF
        if elapsed == 0 or self.edge_us == 0:
            return 0.0
        moved = ((self.count - earlier.count + 2**31) & 0xFFFFFFFF) - 2**31
        return moved * 1e6 / elapsed


def _state(reply: p.EncoderReadReply | p.EncoderPresetReply | p.EncoderReport) -> EncoderState:
    return EncoderState(reply.count, reply.invalid, reply.edge_us)


class EncoderPin(PinHandle):
    """Pin B of an encoder: it holds its pin in :attr:`Board.roles` for the encoder."""

    ROLE = "quadrature encoder"

    def __init__(self, board: BoardCore, pin: DigitalPin, encoder: Encoder) -> None:
        super().__init__(board, pin)
        self.encoder = encoder

    async def release(self) -> None:
        """End the encoder (both pins)."""
        await self.encoder.release()


class Encoder(PinHandle):
    """A quadrature encoder decoded by the board; :attr:`pin` is A, :attr:`pin_b` is B.

    Forward (counting up) is A leading B: A rises while B is low.  Swap the pins (or the
    wires) to count the other way.
    """

    ROLE = "quadrature encoder"

    def __init__(
        self, board: BoardCore, pin: DigitalPin, pin_b: DigitalPin, slot: int, mode: p.EncoderMode
    ) -> None:
        super().__init__(board, pin)
        self.pin_b = pin_b
        self.slot = slot
        self.mode = mode
        self.partner = EncoderPin(board, pin_b, self)

    def __repr__(self) -> str:
        return (
            f"<Encoder {self.pin.name}/{self.pin_b.name} x{int(self.mode)} "
            f"slot {self.slot} on {self.board}>"
        )

    @property
    def other_pins(self) -> tuple[DigitalPin, ...]:
        """The pins besides :attr:`pin` this role holds (released with it)."""
        return (self.pin_b,)

    async def read(self) -> EncoderState:
        """The count, invalid transitions and last edge time, read from the board now."""
        self.check_usable()
        return _state(await self.board.request(p.EncoderRead(self.slot)))

    async def count(self) -> int:
        """The count alone."""
        return (await self.read()).count

    async def preset(self, value: int = 0) -> EncoderState:
        """Set the count to ``value`` and clear the invalid transitions in one step;
        returns the state just before (so no edge falls between a read and a reset)."""
        self.check_usable()
        if not -(2**31) <= value < 2**31:
            raise ValueRangeError("encoder preset", value, "a signed 32-bit count")
        return _state(await self.board.request(p.EncoderPreset(self.slot, value)))

    async def reset(self) -> EncoderState:
        """:meth:`preset` to 0."""
        return await self.preset(0)

    def reports(
        self, every: int, *, buffer: int = DEFAULT_CHANGE_BUFFER
    ) -> AbstractAsyncContextManager[EncoderReports]:
        """``async with enc.reports(every=100) as reports: async for state in reports:``
        the board reports the state every ``every`` counts moved either way (1-65535)."""
        self.check_usable()
        return watch_encoder(self.board, self.slot, every, buffer)

    async def release(self) -> None:
        """End the encoder on the board; both pins become free."""
        self.check_usable()
        await self.board.release(self.pin)


class EncoderReports(IntervalReports[EncoderState]):
    """Async iterator over a watched encoder's reports (EncoderReport events); see
    :class:`~arduinoio_async.board.changes.IntervalReports` for :attr:`missed` and
    :attr:`dropped` (an encoder's count moves either way: the distance is signed)."""

    WHAT = "an encoder"

    def __init__(self, link: Transport, slot: int, every: int, buffer: int) -> None:
        self.slot = slot
        super().__init__(link, every, buffer)

    def _on_event(self, event: p.Event) -> None:
        if not isinstance(event, p.EncoderReport) or event.slot != self.slot:
            return
        self._note_count(
            event.count, lambda count, last: abs(((count - last + 2**31) & 0xFFFFFFFF) - 2**31)
        )
        self._put(_state(event))


@asynccontextmanager
async def watch_encoder(
    board: BoardCore, slot: int, every: int, buffer: int = DEFAULT_CHANGE_BUFFER
) -> AsyncIterator[EncoderReports]:
    """Reports of encoder ``slot`` every ``every`` counts for the block."""
    if not 1 <= every <= 0xFFFF:
        raise ValueRangeError("encoder report interval (counts)", every, "1-65535")
    reports = EncoderReports(board.link, slot, every, buffer)
    async with board.watches.subscribe(
        ("encoder", slot),
        p.EncoderWatch(slot, every),
        p.EncoderWatch(slot, 0),
        reports,
        conflict=lambda held: (
            f"encoder slot {slot} already reports every {getattr(held, 'every', '?')} counts "
            f"on {board}: one interval per encoder (end that block or use the same interval)"
        ),
    ):
        yield reports
    reports.raise_unreported()
