"""The monitor's RC inputs view: each pulse-width input's width, stick position and signal.

An RC receiver channel is a pin whose pulses the board times (``board.pulse_input``), so
its value is neither a level nor a count: a :class:`~arduinoio_async.monitor._devices.DeviceView`
whose rows are the inputs in the board's role table (set up from the page or by the robot
program that embeds the monitor), read with one small request each, and whose control
sets one up on a chosen pin.  A lost signal shows as lost, with the last width, never as
a position.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .. import protocol as p
from ..board.pulse_inputs import PulseInput, scale_position
from ..errors import UsageError
from ..protocol.pins import DigitalPin
from ._devices import Action, DeviceView

__all__ = ["RcInputView"]


class RcInputView(DeviceView):
    """RC pulse-width inputs: width (us), position -1..1 and lost; set up from the page."""

    key = "rc_inputs"
    feature = p.Feature.PULSE_IN

    def inputs(self) -> list[PulseInput]:
        """The pulse inputs in the board's role table, by slot."""
        found = {
            claim.handle.slot: claim.handle
            for claim in self.board.roles.values()
            if isinstance(claim.handle, PulseInput) and not claim.handle.released
        }
        return [found[slot] for slot in sorted(found)]

    async def read_rows(self) -> list[dict[str, object]]:
        rows: list[dict[str, object]] = []
        for rc in self.inputs():
            state = await rc.read()
            position = (
                None
                if state.lost
                else round(scale_position(state.width_us, rc.low_us, rc.centre_us, rc.high_us), 3)
            )
            rows.append(
                {
                    "slot": rc.slot,
                    "pin": rc.pin.name,
                    "width_us": state.width_us,
                    "position": position,
                    "lost": state.lost,
                }
            )
        return rows

    def actions(self) -> dict[str, Action]:
        return {"rc_input": self._set_up}

    async def _set_up(self, args: Mapping[str, Any]) -> int:
        """``{"pin": "D7", "timeout_ms": 100}``: a new input; answers its slot."""
        try:
            pin = DigitalPin[str(args["pin"])]
        except KeyError:
            raise UsageError("pin must be a digital pin name such as D7") from None
        rc = await self.board.pulse_input(pin, timeout_ms=int(args.get("timeout_ms", 100)))
        await self.read()
        return rc.slot
