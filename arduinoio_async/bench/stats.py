"""Percentiles of latency samples."""

from __future__ import annotations

import statistics
from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["Summary", "summarize"]


@dataclass(frozen=True)
class Summary:
    """Latency percentiles in milliseconds."""

    n: int
    p50: float
    p90: float
    p99: float
    mean: float

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _percentile(ordered: list[float], fraction: float) -> float:
    index = min(len(ordered) - 1, max(0, round(fraction * (len(ordered) - 1))))
    return ordered[index]


def summarize(samples_ms: list[float]) -> Summary:
    ordered = sorted(samples_ms)
    if not ordered:
        return Summary(0, float("nan"), float("nan"), float("nan"), float("nan"))
    return Summary(
        len(ordered),
        _percentile(ordered, 0.5),
        _percentile(ordered, 0.9),
        _percentile(ordered, 0.99),
        statistics.fmean(ordered),
    )
