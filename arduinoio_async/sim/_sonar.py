"""The virtual Uno's HC-SR04 style sonars (``firmware/sim/sonar_model.c``).

Mixed into :class:`~arduinoio_async.sim.VirtualUno`: ``await uno.sonar("D7", "D8",
distance_mm=500)`` wires a sonar whose trigger is D7 and echo D8; a >= 10 us trigger pulse
from the board is answered with an echo pulse of the sound's round trip (2 * distance /
343 m/s: 58.3 us per cm) after the part's burst delay, or the part's "nothing heard" pulse
(38 ms) when the distance is 0 or out of range.  :meth:`SonarModelMethods.sonar_status`
gives the ground truth the tests compare the board's distances with: the triggers seen
(times and widths), the echo widths sent, and the overlaps (a trigger while another
sonar's measurement ran).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["SonarModel", "SonarModelMethods", "SonarStatus", "SonarTrigger"]


@dataclass(frozen=True, slots=True)
class SonarTrigger:
    """One trigger pulse the model saw (simulated microseconds)."""

    #: When the trigger rose, and how long it stayed high.
    at_us: float
    width_us: float
    #: The echo it got: its width, 0.0 for "nothing heard", -1.0 while none was sent.
    echo_us: float


@dataclass(frozen=True, slots=True)
class SonarModel:
    """One sonar's ground truth."""

    trigger: int
    echo: int
    distance_mm: float
    #: A measurement runs (burst delay or echo high).
    busy: bool
    #: Trigger pulses seen; shorter than 10 us; ignored because a measurement ran.
    triggers: int
    short_triggers: int
    ignored: int
    #: Echoes sent with a distance, and "nothing heard" pulses.
    echoes: int
    no_echoes: int
    #: The last echo's width (cycles / 16), 0.0 if it was "nothing heard".
    last_echo_us: float
    #: The last 16 triggers, oldest first.
    log: tuple[SonarTrigger, ...]


@dataclass(frozen=True, slots=True)
class SonarStatus:
    """Every sonar's ground truth and the overlaps between them."""

    sim_us: float
    #: Triggers that came while another sonar's measurement ran.
    overlaps: int
    sonars: tuple[SonarModel, ...]

    def on(self, trigger: int) -> SonarModel:
        """The sonar whose trigger is pin number ``trigger``."""
        for sonar in self.sonars:
            if sonar.trigger == trigger:
                return sonar
        raise KeyError(f"no sonar with its trigger on D{trigger}")


class SonarModelMethods:
    """``sonar``, ``sonar_status``: the sonar models of a virtual Uno."""

    async def command(self, cmd: str, **params: Any) -> dict[str, Any]:
        """One control-channel command (VirtualUno's)."""
        raise NotImplementedError

    async def sonar(
        self,
        trigger: int | str,
        echo: int | str | None = None,
        *,
        distance_mm: float,
        range_mm: float | None = None,
        speed_m_s: float | None = None,
        delay_us: float | None = None,
        noecho_us: float | None = None,
    ) -> None:
        """Wire a sonar (trigger and echo pins) at ``distance_mm`` (0: nothing in range), or
        move the one on ``trigger`` (its echo pin may be left out).  Unnamed settings keep
        their values (new sonar: range 4000 mm, 343.0 m/s, 300 us delay, 38 ms no-echo)."""
        params: dict[str, Any] = {"trigger": trigger, "distance_mm": distance_mm}
        if echo is not None:
            params["echo"] = echo
        for key, value in (
            ("range_mm", range_mm),
            ("speed_m_s", speed_m_s),
            ("delay_us", delay_us),
            ("noecho_us", noecho_us),
        ):
            if value is not None:
                params[key] = value
        await self.command("sonar", **params)

    async def sonar_status(self) -> SonarStatus:
        """Every sonar's ground truth."""
        reply = await self.command("sonar_status")
        sonars = tuple(
            SonarModel(**{**s, "log": tuple(SonarTrigger(**t) for t in s["log"])})
            for s in reply["sonars"]
        )
        return SonarStatus(reply["sim_us"], reply["overlaps"], sonars)
