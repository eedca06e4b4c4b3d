"""The blocking twin of :class:`~arduinoio_async.board.pulse_inputs.PulseInput`;
``BlockingBoard.pulse_input`` returns it."""

from __future__ import annotations

from ..board.pulse_inputs import PulseInput, PulseState
from ._handles import _BlockingPin

__all__ = ["BlockingPulseInput"]


class BlockingPulseInput(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.pulse_inputs.PulseInput`: an RC channel's
    last width, its age and whether the signal is lost."""

    handle: PulseInput

    @property
    def slot(self) -> int:
        """The board's slot (0-5): the input's place in a stream's ``pulse_widths``."""
        return self.handle.slot

    def read(self) -> PulseState:
        """The last width, its age and whether the signal is lost, read from the board now."""
        return self._runner.call(self.handle.read)

    def position(self) -> float | None:
        """The stick position -1..1 by the end points; None while the signal is lost."""
        return self._runner.call(self.handle.position)

    def throttle(self) -> float | None:
        """The throttle 0..1 by the end points; None while the signal is lost."""
        return self._runner.call(self.handle.throttle)
