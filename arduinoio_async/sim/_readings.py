"""What the virtual Uno's harness reports about a pin, its pulses and the firmware's cycles.

Plain records of the harness's ground truth (the circuit's view of a pin, the pulses it
captured, the CPU cycles the firmware spent on a request), kept apart from the process
management in :mod:`.virtual_uno` that fetches them.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CircuitPin", "FirmwareCycles", "PulseStats"]


@dataclass(frozen=True, slots=True)
class CircuitPin:
    """A pin as the simulated circuit sees it (DDR/PORT bits and the resulting level)."""

    pin: int
    ddr: int
    port: int
    level: int
    mv: int | None = None


@dataclass(frozen=True, slots=True)
class PulseStats:
    """Recent pulses captured on a pin; times are simulated microseconds.

    ``high_us`` and ``period_us`` hold the last 32 values; ``highs`` and ``periods`` count
    all values recorded since the last clear, so a poller can tell which entries are new.
    """

    pin: int
    count: int
    falls: int
    level: int
    high_us: tuple[float, ...]
    period_us: tuple[float, ...]
    highs: int = 0
    periods: int = 0
    #: Simulated time of the rise that started each entry of ``high_us``.
    rise_us: tuple[float, ...] = ()
    #: Simulated time of the pin's last level change (None: it never changed).
    last_edge_us: float | None = None


@dataclass(frozen=True, slots=True)
class FirmwareCycles:
    """Simulated CPU cycles from the firmware reading a request's last byte from UDR0 to its
    first reply byte written to UDR0 (the firmware's own work, independent of the baud rate).

    ``last`` is ``None`` until a request got a reply.  16 cycles are one microsecond.
    """

    samples: tuple[int, ...]
    last: int | None

    @property
    def samples_us(self) -> tuple[float, ...]:
        """The samples in microseconds, which is what latency budgets are written in."""
        return tuple(s / 16.0 for s in self.samples)
