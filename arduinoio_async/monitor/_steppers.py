"""The steppers of a monitored board: position and target, read for the page (issue 26).

A stepper's motion runs on the board, so nothing in the panel's own sources (stream,
change events, counts) shows it.  :class:`StepperView` reads every stepper the board's
role table holds (``StepperRead``, one small request each) every :data:`STEPPER_INTERVAL`
and tells the panel when a position, target or state changed; the page shows one line per
stepper ("stepper 0 (D2/D3): 1200 -> 2000, moving").
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

import anyio

from .. import protocol as p
from ..board.steppers import StepperPin
from ..errors import ArduinoIOError

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["STEPPER_INTERVAL", "StepperView"]

logger = logging.getLogger(__name__)

#: Seconds between two reads of the steppers.
STEPPER_INTERVAL = 0.2


class StepperView:
    """The board's steppers as the page shows them, kept fresh."""

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        self.board = board
        self.rows: list[dict[str, object]] = []
        self._on_change = on_change

    def _steppers(self) -> dict[int, list[str]]:
        """Stepper index -> its step and direction pins' names, from the role table."""
        found: dict[int, list[str]] = {}
        for pin, claim in self.board.roles.items():
            handle = claim.handle
            if isinstance(handle, StepperPin) and not handle.released:
                found.setdefault(handle.stepper_index, []).append(pin.name)
        return found

    async def read(self) -> None:
        """Read every stepper once; the panel hears of a change."""
        rows: list[dict[str, object]] = []
        for index, pins in sorted(self._steppers().items()):
            try:
                r = await self.board.request(p.StepperRead(index))
            except ArduinoIOError as exc:
                logger.debug("stepper %d not read: %s", index, exc)
                continue
            rows.append(
                {
                    "index": index,
                    "pins": "/".join(pins),
                    "position": r.position,
                    "target": r.target,
                    "speed": r.speed,
                    "moving": r.moving,
                }
            )
        if rows != self.rows:
            self.rows = rows
            self._on_change()

    async def run(self) -> None:
        """Read the steppers every STEPPER_INTERVAL until cancelled."""
        while True:
            if self.board.connected:
                await self.read()
            await anyio.sleep(STEPPER_INTERVAL)
