"""RC pulse-width inputs: the :class:`PulseInput` handle and its :class:`PulseState`.

``rc = await board.pulse_input(D4, timeout_ms=100)`` times the high pulses on a pin on the
board (both edges stamped in the pin-change interrupt with the board's microsecond clock,
:mod:`arduinoio_async.protocol.commands.pulse_in`): an RC receiver's channel, 1,000-2,000
us every ~20 ms.  A state carries the last width, how old it is, and whether the signal is
lost (no pulse for ``timeout_ms``); a lost signal never passes for a fresh width.

The width maps to a stick position with :meth:`PulseInput.position` (-1..1 around a
centre) or :meth:`PulseInput.throttle` (0..1), with end points the handle keeps
(:attr:`PulseInput.low_us`, :attr:`PulseInput.centre_us`, :attr:`PulseInput.high_us`;
calibrate them to the transmitter).  An RC override is this input plus the failsafe: arm
the failsafe as usual, and while ``state.lost`` is true stop steering from the receiver.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin
from .handles import PinHandle

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["PulseInput", "PulseState", "pulse_input_slots", "scale_position", "scale_throttle"]

logger = logging.getLogger(__name__)

#: The RC end points most transmitters send (microseconds).
DEFAULT_LOW_US = 1000
DEFAULT_CENTRE_US = 1500
DEFAULT_HIGH_US = 2000


@dataclass(frozen=True, slots=True)
class PulseState:
    """A pulse input's last width, its age and the signal state, as the board saw them."""

    #: The last complete high pulse in microseconds (0: none since set-up).
    width_us: int
    #: Milliseconds since that pulse ended (65535: that long or more, or none yet).
    age_ms: int
    #: No pulse ended for the input's timeout: the width is old, do not steer by it.
    lost: bool


def scale_position(width_us: float, low_us: float, centre_us: float, high_us: float) -> float:
    """``width_us`` as -1..1: ``low_us`` -> -1, ``centre_us`` -> 0, ``high_us`` -> 1, clamped."""
    if width_us >= centre_us:
        x = (width_us - centre_us) / (high_us - centre_us)
    else:
        x = (width_us - centre_us) / (centre_us - low_us)
    return max(-1.0, min(1.0, x))


def scale_throttle(width_us: float, low_us: float, high_us: float) -> float:
    """``width_us`` as 0..1: ``low_us`` -> 0, ``high_us`` -> 1, clamped."""
    return max(0.0, min(1.0, (width_us - low_us) / (high_us - low_us)))


def pulse_input_slots(board: BoardCore) -> int:
    """How many slots the board's stream block carries: the highest slot a live
    :class:`PulseInput` holds, + 1 (0 for none), as the board counts them at START."""
    return max(
        (
            claim.handle.slot + 1
            for claim in board.roles.values()
            if isinstance(claim.handle, PulseInput) and not claim.handle.released
        ),
        default=0,
    )


def _state(reply: p.PulseInReadReply | p.PulseInSignal) -> PulseState:
    return PulseState(reply.width_us, reply.age_ms, bool(reply.lost))


class PulseInput(PinHandle):
    """High-pulse widths on one pin, timed by the board (an RC receiver's channel)."""

    ROLE = "pulse-width input"

    def __init__(
        self,
        board: BoardCore,
        pin: DigitalPin,
        slot: int,
        timeout_ms: int,
        *,
        low_us: int = DEFAULT_LOW_US,
        centre_us: int = DEFAULT_CENTRE_US,
        high_us: int = DEFAULT_HIGH_US,
    ) -> None:
        super().__init__(board, pin)
        if not low_us < centre_us < high_us:
            raise ValueRangeError(
                "pulse input end points", (low_us, centre_us, high_us), "low < centre < high"
            )
        self.slot = slot
        self.timeout_ms = timeout_ms
        self.low_us = low_us
        self.centre_us = centre_us
        self.high_us = high_us

    def __repr__(self) -> str:
        return f"<PulseInput {self.pin.name} slot {self.slot} on {self.board}>"

    async def read(self) -> PulseState:
        """The last width, its age and whether the signal is lost, read from the board now."""
        self.check_usable()
        return _state(await self.board.request(p.PulseInRead(self.slot)))

    def on_signal(self, callback: Callable[[PulseState], None]) -> Callable[[], None]:
        """Call ``callback(state)`` when this input's signal is lost (``state.lost``: no
        pulse for ``timeout_ms``, with the last width) or comes back (the first pulse after a
        loss or after set-up, with its width): the board's PulseInSignal events, sent once
        per change, so an RC override hears of a loss without polling.  Returns the
        unsubscriber.  The callback runs in the link's reader: keep it short (set an
        event, send to a stream); its exceptions are logged.
        """
        slot = self.slot

        def on_event(event: p.Event) -> None:
            if isinstance(event, p.PulseInSignal) and event.slot == slot and not self.released:
                try:
                    callback(_state(event))
                except Exception:  # a listener's bug must not hurt the link
                    logger.exception("%r: on_signal callback %r failed", self, callback)

        return self.board.link.subscribe(on_event)

    async def position(self) -> float | None:
        """The stick position -1..1 by the end points; None while the signal is lost."""
        state = await self.read()
        if state.lost:
            return None
        return scale_position(state.width_us, self.low_us, self.centre_us, self.high_us)

    async def throttle(self) -> float | None:
        """The throttle 0..1 by the low and high end points; None while the signal is lost."""
        state = await self.read()
        if state.lost:
            return None
        return scale_throttle(state.width_us, self.low_us, self.high_us)
