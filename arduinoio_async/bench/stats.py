"""The one definition of a percentile that every benchmark figure uses.

A percentile here is the **linear interpolation between the two nearest ranks** (the
"inclusive" definition: Hyndman and Fan's type 7, numpy's and R's default,
``statistics.quantiles(method="inclusive")``): for ``n`` sorted samples ``x[0..n-1]``
and a fraction ``q``, the position is ``h = q * (n - 1)``, and the percentile is
``x[floor(h)] + (h - floor(h)) * (x[floor(h) + 1] - x[floor(h)])``.  So ``q = 0`` is the
minimum, ``q = 1`` the maximum, and ``q = 0.5`` is exactly :func:`statistics.median`.

Why this one: the benchmarks also report medians of rounds and of per-round ratios
(robust against a busy neighbour on the shared machine); with this definition the p50
of a result and every median in it are the same statistic, and anyone can recompute a
figure from stored samples with ``numpy.percentile`` or ``statistics.quantiles(...,
method="inclusive")``.  It moves continuously with the data (nearest-rank jumps a whole
sample when one sample is added), which matters when before/after runs of a few hundred
samples are compared.  The price: a tail percentile of a small sample may lie between two
observed values; results keep ``n`` next to every percentile so a reader can judge that.

Until this module, four definitions were in use (rounded index, floor index on
``n - 1``, floor index on ``n``, and ``statistics.quantiles``' default "exclusive"
one), so figures from different result files were not comparable.  Every result file
records :data:`STATS_VERSION` as ``stats_version``: 1 is this definition; 0 marks a
file made before it (its percentiles follow the script of that time, said in its note).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["STATS_VERSION", "Summary", "median", "percentile", "quartiles", "summarize"]

#: Written into every result file as ``stats_version``.  Bump it when a definition here
#: changes, and re-generate the recorded results (or re-derive them from their samples).
STATS_VERSION = 1


def percentile(values: Iterable[float], fraction: float) -> float:
    """The ``fraction`` (0 to 1) percentile of ``values``, linearly interpolated.

    Raises ValueError for no values or a fraction outside [0, 1].
    """
    ordered = sorted(values)
    if not ordered:
        raise ValueError("percentile of no values")
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"percentile fraction {fraction} is not between 0 and 1")
    return _interpolated(ordered, fraction)


def _interpolated(ordered: Sequence[float], fraction: float) -> float:
    position = fraction * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (position - low) * (ordered[high] - ordered[low])


def median(values: Iterable[float]) -> float:
    """The 0.5 percentile (the same as :func:`statistics.median`)."""
    return percentile(values, 0.5)


def quartiles(values: Iterable[float]) -> tuple[float, float]:
    """The 0.25 and 0.75 percentiles: the interquartile range results report as spread."""
    ordered = sorted(values)
    if not ordered:
        raise ValueError("quartiles of no values")
    return _interpolated(ordered, 0.25), _interpolated(ordered, 0.75)


@dataclass(frozen=True)
class Summary:
    """Percentiles of one set of samples (in the samples' unit, usually milliseconds)."""

    n: int
    p50: float
    p90: float
    p99: float
    mean: float

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def rounded(self, digits: int, suffix: str = "") -> dict[str, Any]:
        """The figures rounded, keys suffixed (``"_ms"``), for a result file's row."""
        figures = {f"{key}{suffix}": round(value, digits) for key, value in asdict(self).items()}
        return {"n": self.n, **{k: v for k, v in figures.items() if k != f"n{suffix}"}}


def summarize(samples: Iterable[float]) -> Summary:
    """n, p50, p90, p99 and mean; all NaN (n 0) for no samples."""
    ordered = sorted(samples)
    if not ordered:
        return Summary(0, math.nan, math.nan, math.nan, math.nan)
    return Summary(
        len(ordered),
        _interpolated(ordered, 0.5),
        _interpolated(ordered, 0.9),
        _interpolated(ordered, 0.99),
        statistics.fmean(ordered),
    )
