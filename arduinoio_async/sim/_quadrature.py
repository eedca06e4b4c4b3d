"""The virtual Uno's quadrature signal generators (``firmware/sim/quadrature.c``).

Mixed into :class:`~arduinoio_async.sim.VirtualUno`: ``await uno.quadrature("D2", "D3",
edges=10_000, rate=50_000, reverse=0.01)`` turns an encoder on a pin pair at a rate in
simulated time; :meth:`QuadratureMethods.quadrature_status` gives the ground truth (the
generator's position in quarter steps, the double steps and glitches it injected) that
the tests compare the board's counts with.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import anyio

__all__ = ["QuadratureGenerator", "QuadratureMethods"]


@dataclass(frozen=True, slots=True)
class QuadratureGenerator:
    """One generator's ground truth (positions in quarter steps: x4 counts)."""

    a: int
    b: int
    active: bool
    #: Quarter steps from where the pair started (forward: A leads B).
    position: int
    #: Edges made (a double step counts two), and still to make.
    edges: int
    left: int
    reversals: int
    #: Double steps (both pins at once: an invalid transition) and glitches injected.
    skips: int
    glitches: int
    #: The latest the harness applied an edge after its due time (simulated us): the
    #: generator's own fidelity (its edges run from the event list, normally exact).
    max_late_us: float = 0.0
    #: The firmware's side: the longest an edge on A or B waited until the CPU entered
    #: the interrupt vector that answers that pin (simulated us; INT0/INT1 or the pin's
    #: pin-change group), where the CPU was when that edge came (its byte address: look
    #: it up with ``avr-addr2line``) and whether interrupts were on then, and how many
    #: edges were measured.  An edge that waits longer than the next edge of the same
    #: encoder is a skipped state: this is the encoder's rate limit.
    max_irq_latency_us: float = 0.0
    max_irq_latency_pc: int = 0
    max_irq_latency_interrupts_on: bool = True
    irq_latency_edges: int = 0


class QuadratureMethods:
    """``quadrature``, ``quadrature_status``, ``wait_quadrature``, ``quadrature_stop``."""

    async def command(self, cmd: str, **params: Any) -> dict[str, Any]:
        """One control-channel command (VirtualUno's)."""
        raise NotImplementedError

    async def quadrature(
        self,
        a: int | str,
        b: int | str,
        *,
        edges: int,
        rate: float,
        reverse: float = 0.0,
        jitter: float = 0.0,
        skip_every: int = 0,
        glitch_every: int = 0,
        glitch_us: float = 1.0,
        direction: int = 1,
        seed: int = 1,
    ) -> None:
        """Start ``edges`` edges on pins ``a``/``b`` at ``rate`` edges per simulated second.

        ``reverse``: probability of a reversal at each edge; ``jitter``: each interval
        varies by up to this fraction; ``skip_every``: every N edges a double step (an
        invalid transition); ``glitch_every``/``glitch_us``: a pulse on one pin that comes
        back.  The same pair again goes on from its position (asynchronous: see
        :meth:`wait_quadrature`).
        """
        await self.command(
            "quadrature",
            a=a,
            b=b,
            edges=edges,
            rate=rate,
            reverse=reverse,
            jitter=jitter,
            skip_every=skip_every,
            glitch_every=glitch_every,
            glitch_us=glitch_us,
            dir=direction,
            seed=seed,
        )

    async def quadrature_status(self) -> list[QuadratureGenerator]:
        """Every generator's ground truth."""
        reply = await self.command("quadrature_status")
        return [QuadratureGenerator(**g) for g in reply["generators"]]

    async def wait_quadrature(self, timeout: float = 30.0) -> list[QuadratureGenerator]:
        """Wait until every generator has made its edges; returns their ground truth."""
        with anyio.fail_after(timeout):
            while True:
                generators = await self.quadrature_status()
                if not any(g.active for g in generators):
                    return generators
                await anyio.sleep(0.01)

    async def quadrature_stop(self) -> None:
        """Stop every generator where it is (its pins hold their levels)."""
        await self.command("quadrature_stop")
