"""The virtual Uno's RC pulse sources (``firmware/sim/rcpulse.c``).

Mixed into :class:`~arduinoio_async.sim.VirtualUno`: ``await uno.rcpulse("D4",
width_us=1500)`` drives a receiver channel's high pulses (every 20 ms by default) on a
pin in simulated time; :meth:`RcPulseMethods.rcpulse_status` gives the ground truth (the
pulses completed, the last one's width measured in CPU cycles, when it ended) the tests
compare the board's widths with; :meth:`RcPulseMethods.rcpulse_stop` is a lost signal.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["RcPulseMethods", "RcPulseSource"]


@dataclass(frozen=True, slots=True)
class RcPulseSource:
    """One source's ground truth (times in simulated microseconds)."""

    pin: int
    active: bool
    #: Pulses completed since the source started on this pin.
    pulses: int
    #: The width and period it is set to.
    width_us: float
    period_us: float
    #: The last completed pulse: how long the pin was high, and when it fell.
    last_width_us: float
    last_end_us: float


class RcPulseMethods:
    """``rcpulse``, ``rcpulse_status``, ``rcpulse_stop``."""

    async def command(self, cmd: str, **params: Any) -> dict[str, Any]:
        """One control-channel command (VirtualUno's)."""
        raise NotImplementedError

    async def rcpulse(
        self, pin: int | str, *, width_us: float, period_us: float = 20_000.0, count: int = 0
    ) -> None:
        """Pulse ``pin`` high for ``width_us`` every ``period_us`` (``count`` pulses, 0: until
        :meth:`rcpulse_stop`).  The same pin again changes the width from the next pulse."""
        await self.command("rcpulse", pin=pin, width_us=width_us, period_us=period_us, count=count)

    async def rcpulse_status(self) -> list[RcPulseSource]:
        """Every source's ground truth."""
        reply = await self.command("rcpulse_status")
        return [RcPulseSource(**s) for s in reply["sources"]]

    async def rcpulse_stop(self, pin: int | str | None = None) -> None:
        """Stop the source on ``pin`` (every source: None) after its pulse under way."""
        if pin is None:
            await self.command("rcpulse_stop")
        else:
            await self.command("rcpulse_stop", pin=pin)
