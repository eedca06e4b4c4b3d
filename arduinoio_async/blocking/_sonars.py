"""The blocking twin of :class:`~arduinoio_async.board.sonars.Sonar`;
``BlockingBoard.sonar`` returns it."""

from __future__ import annotations

from ..board.sonars import Sonar, SonarReading
from ._handles import _BlockingPin

__all__ = ["BlockingSonar"]


class BlockingSonar(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.sonars.Sonar`: an HC-SR04 style ranger the
    board fires in turn with the others; distances in mm, None for "no echo"."""

    handle: Sonar

    @property
    def slot(self) -> int:
        """The board's slot (0-3): the sonar's turn and its place in a stream's ``sonars``."""
        return self.handle.slot

    def read(self) -> SonarReading:
        """The latest reading (distance, echo width, age, readings so far), from the board now."""
        return self._runner.call(self.handle.read)

    def distance_mm(self) -> int | None:
        """The latest distance in millimetres; None for "no echo" or before the first."""
        return self._runner.call(self.handle.distance_mm)
