"""The one percentile definition (``arduinoio_async.bench.stats``) and the result files
that must say which definition made them.

The expected values are worked by hand from the definition (linear interpolation between
the two nearest ranks, position ``q * (n - 1)``), not taken from the module's output;
they also equal numpy's default and ``statistics.quantiles(method="inclusive")``.
"""

from __future__ import annotations

import json
import re
import statistics
from pathlib import Path

import pytest

from arduinoio_async.bench.stats import (
    STATS_VERSION,
    median,
    percentile,
    quartiles,
    summarize,
)
from benchmarks._results import merge_result, write_result

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"


@pytest.mark.parametrize(
    ("values", "fraction", "expected"),
    [
        ([1, 2, 3, 4], 0.9, 3.7),  # position 2.7: 3 + 0.7 * (4 - 3)
        ([1, 2, 3, 4], 0.5, 2.5),  # the median of an even count: the mean of the middle two
        ([4, 1, 3, 2], 0.25, 1.75),  # order of the input does not matter; position 0.75
        ([10, 20, 30, 40, 50], 0.9, 46.0),  # position 3.6: 40 + 0.6 * 10
        ([10, 20, 30, 40, 50], 0.99, 49.6),  # position 3.96
        ([10, 20, 30, 40, 50], 0.5, 30.0),  # an odd count's median is a sample
        ([10, 20, 30, 40, 50], 0.0, 10.0),
        ([10, 20, 30, 40, 50], 1.0, 50.0),
        ([7], 0.9, 7.0),
        ([0, 100], 0.1, 10.0),
    ],
)
def test_percentile_interpolates_linearly_between_the_nearest_ranks(
    values: list[float], fraction: float, expected: float
) -> None:
    assert percentile(values, fraction) == pytest.approx(expected)


def test_percentile_agrees_with_the_inclusive_method_and_the_median() -> None:
    values = [0.31, 0.2, 0.25, 1.9, 0.22, 0.27, 0.24, 0.5, 0.23, 0.26, 0.21]
    deciles = statistics.quantiles(values, n=10, method="inclusive")
    assert [percentile(values, k / 10) for k in range(1, 10)] == pytest.approx(deciles)
    assert median(values) == statistics.median(values)
    assert median([1, 2, 3, 10]) == statistics.median([1, 2, 3, 10]) == 2.5
    assert quartiles([1, 2, 3, 4, 5, 6, 7, 8, 9]) == (3.0, 7.0)


def test_summary_uses_the_same_definition() -> None:
    summary = summarize([10, 20, 30, 40, 50])
    assert (summary.n, summary.p50, summary.mean) == (5, 30.0, 30.0)
    assert summary.p90 == pytest.approx(46.0) and summary.p99 == pytest.approx(49.6)
    assert summary.rounded(1, "_ms") == {
        "n": 5,
        "p50_ms": 30.0,
        "p90_ms": 46.0,
        "p99_ms": 49.6,
        "mean_ms": 30.0,
    }
    assert summarize([]).n == 0


@pytest.mark.parametrize(("values", "fraction"), [([], 0.5), ([1.0], 1.5), ([1.0], -0.1)])
def test_percentile_refuses_no_values_and_fractions_outside_0_to_1(
    values: list[float], fraction: float
) -> None:
    with pytest.raises(ValueError, match="percentile"):
        percentile(values, fraction)


def test_every_recorded_result_says_which_statistics_made_it() -> None:
    files = sorted(RESULTS.glob("*.json"))
    assert files
    for path in files:
        data = json.loads(path.read_text())
        assert isinstance(data, dict), f"{path.name}: a result file is an object"
        version = data.get("stats_version")
        assert isinstance(version, int) and 0 <= version <= STATS_VERSION, path.name
        if version < STATS_VERSION:  # an older file says what its percentiles are
            assert "stats_note" in data, f"{path.name}: stats_version {version} without a note"


# Records still at stats_version 0 that are due to be re-generated with the current
# statistics: remove a name when its file is re-run. The test below fails if a name here is
# re-generated or gone, so the list cannot go stale. Empty since the re-run of 2026-11-26
# (issue 24 item 5).
AWAITING_REGENERATION: tuple[str, ...] = ()


def test_a_result_without_samples_statistics_is_historical_or_awaits_a_rerun() -> None:
    """A stats_version 0 file holds figures that cannot be re-derived (no samples): it is
    either explicitly marked ``historical`` (it records code that no longer exists, with a
    sentence saying so) or listed as awaiting a re-run; nothing else may say 0."""
    unmarked = []
    for path in sorted(RESULTS.glob("*.json")):
        data = json.loads(path.read_text())
        if data.get("stats_version") != 0:
            continue
        historical = data.get("historical")
        if isinstance(historical, str) and historical.strip():
            continue
        if path.name not in AWAITING_REGENERATION:
            unmarked.append(path.name)
    assert unmarked == [], f"stats_version 0 without a 'historical' reason: {unmarked}"
    stale = [
        name
        for name in AWAITING_REGENERATION
        if not (RESULTS / name).exists()
        or json.loads((RESULTS / name).read_text()).get("stats_version") != 0
    ]
    assert stale == [], f"re-generated or gone, remove from AWAITING_REGENERATION: {stale}"


def test_merging_keys_into_a_result_file_keeps_the_others(tmp_path: Path) -> None:
    path = tmp_path / "link.json"
    write_result(path, {"command": "x", "a": 1, "b": {"kept": True}})
    merge_result(path, lambda data: data.update(a=2, c=3))
    data = json.loads(path.read_text())
    assert data == {
        "command": "x",
        "stats_version": STATS_VERSION,
        "a": 2,
        "b": {"kept": True},
        "c": 3,
    }
    assert list(data)[:2] == ["command", "stats_version"]


def test_no_source_edits_sys_path() -> None:
    """Benchmarks are a package (``python -m benchmarks.NAME``): nothing imports through
    an edited ``sys.path``."""
    edits = [
        f"{path.relative_to(REPO)}:{number}"
        for folder in ("arduinoio_async", "benchmarks", "tests", "examples")
        for path in (REPO / folder).rglob("*.py")
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if re.search(r"sys\.path\.(insert|append)|sys\.path\s*\+?=", line)
        and path.name != "test_bench_stats.py"
    ]
    assert edits == []
