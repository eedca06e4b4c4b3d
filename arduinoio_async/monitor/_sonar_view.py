"""The monitor's sonar panel: each sonar's latest distance, set up from the page.

A sonar is two pins and a reading that is neither a level nor a count, so it is a
:class:`~arduinoio_async.monitor._devices.DeviceView`: a row per sonar in the board's role
table (pins, distance or "no echo", age, readings), read every
:data:`~arduinoio_async.monitor._devices.READ_INTERVAL`; the page adds one by its trigger
and echo pins.  The board fires the sonars itself, so reading them costs one READ each.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .. import protocol as p
from ..board.sonars import Sonar
from ..errors import UsageError
from ..protocol.pins import DigitalPin
from ._devices import Action, DeviceView

__all__ = ["SonarView"]


class SonarView(DeviceView):
    """HC-SR04 sonars: distance in mm (None: no echo), age and readings; add from the page."""

    key = "sonars"
    feature = p.Feature.SONAR

    def sonars(self) -> list[Sonar]:
        """The sonars in the board's role table, by slot."""
        found = {
            claim.handle.slot: claim.handle
            for claim in self.board.roles.values()
            if isinstance(claim.handle, Sonar) and not claim.handle.released
        }
        return [found[slot] for slot in sorted(found)]

    async def read_rows(self) -> list[dict[str, object]]:
        rows: list[dict[str, object]] = []
        for sonar in self.sonars():
            reading = await sonar.read()
            rows.append(
                {
                    "slot": sonar.slot,
                    "pins": f"{sonar.pin.name}/{sonar.echo_pin.name}",
                    "distance_mm": reading.distance_mm,
                    "no_echo": reading.no_echo,
                    "age_ms": reading.age_ms,
                    "readings": reading.readings,
                }
            )
        return rows

    def actions(self) -> dict[str, Action]:
        return {"sonar": self._set_up}

    async def _set_up(self, args: Mapping[str, Any]) -> int:
        """``{"trigger": "D7", "echo": "D8"}``: a new sonar; answers its slot."""
        pins = []
        for name in ("trigger", "echo"):
            try:
                pins.append(DigitalPin[str(args.get(name, ""))])
            except KeyError:
                raise UsageError(f"{name} must be a digital pin name such as D7") from None
        sonar = await self.board.sonar(pins[0], pins[1])
        await self.read()
        return sonar.slot
