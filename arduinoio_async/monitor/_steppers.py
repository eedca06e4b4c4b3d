"""The steppers of a monitored board: position and target, read for the page.

A stepper's motion runs on the board, so nothing in the panel's own sources (stream,
change events, counts) shows it.  :class:`StepperView` reads every stepper the board's
role table holds (``StepperRead``, one small request each) every
:data:`~._devices.READ_INTERVAL` and tells the panel when a position, target or state
changed; the page shows one line per stepper ("stepper 0 (D2/D3): 1200 -> 2000, moving").
"""

from __future__ import annotations

from .. import protocol as p
from ..board.steppers import StepperPin
from ._devices import DeviceView

__all__ = ["StepperView"]


class StepperView(DeviceView):
    """The board's steppers as the page shows them, kept fresh."""

    key = "steppers"
    feature = p.Feature.STEPPER

    def _steppers(self) -> dict[int, list[str]]:
        """Stepper index -> its step and direction pins' names, from the role table."""
        found: dict[int, list[str]] = {}
        for pin, claim in self.board.roles.items():
            handle = claim.handle
            if isinstance(handle, StepperPin) and not handle.released:
                found.setdefault(handle.stepper_index, []).append(pin.name)
        return found

    async def read_rows(self) -> list[dict[str, object]]:
        rows: list[dict[str, object]] = []
        for index, pins in sorted(self._steppers().items()):
            r = await self.board.request(p.StepperRead(index))
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
        return rows
