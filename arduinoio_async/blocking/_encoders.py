"""The blocking twin of :class:`~arduinoio_async.board.encoders.Encoder`;
``BlockingBoard.encoder`` returns it."""

from __future__ import annotations

from ..board.encoders import Encoder, EncoderState
from ._handles import _BlockingPin

__all__ = ["BlockingEncoder"]


class BlockingEncoder(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.encoders.Encoder`: a quadrature encoder's count,
    invalid transitions and velocity (``state.velocity_since(earlier)``)."""

    handle: Encoder

    @property
    def slot(self) -> int:
        """The board's slot (0-3): the encoder's place in a stream's ``encoders``."""
        return self.handle.slot

    def read(self) -> EncoderState:
        """The count, invalid transitions and last edge time, read from the board now."""
        return self._runner.call(self.handle.read)

    def count(self) -> int:
        """The count alone."""
        return self._runner.call(self.handle.count)

    def preset(self, value: int = 0) -> EncoderState:
        """Set the count (and clear the invalid transitions); returns the state before."""
        return self._runner.call(self.handle.preset, value)

    def reset(self) -> EncoderState:
        """:meth:`preset` to 0."""
        return self._runner.call(self.handle.reset)
