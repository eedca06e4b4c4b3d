"""Recompute a stored result's figures from its stored samples with the current statistics.

When :data:`arduinoio_async.bench.stats.STATS_VERSION` changes, results whose samples are
in the file need no re-run (a re-run on a differently loaded machine would change the
figures for another reason): this recomputes every figure the samples determine and
stamps the file with the new ``stats_version`` and a ``rederived`` note.  It knows two
kinds of file:

- ``arduinoio bench --json`` output (``latest.json``, ``host-*.json``, ...): each
  command's ``latency`` from its ``samples_ms``; the host scenario's per-round ratio
  medians, quartiles and spreads from the stored ``*_ratios`` (the library-over-minimal
  quartiles only where the per-round values ``*_over_minimal`` are stored);
- ``benchmarks.network_bench`` output (``network*.json``): every round-trip figure from
  ``samples_ms`` (:func:`benchmarks.network_bench.figures`).

The stored samples are rounded (1 us in bench files, 0.1 us in network files), so a
recomputed percentile can differ from one computed at the run by that much.

    .venv/bin/python -m benchmarks.rederive benchmarks/results/latest.json [...]
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Any

from arduinoio_async.bench.stats import STATS_VERSION, median, quartiles, summarize

from ._results import stamped, write_result
from .network_bench import figures as network_figures

NOTE = (
    "figures recomputed from the stored samples with stats_version {version} "
    "(python -m benchmarks.rederive); the samples and the command are as recorded"
)


def rederive_bench(data: dict[str, Any]) -> list[str]:
    """Recompute an ``arduinoio bench`` result in place; returns what could not be."""
    left: list[str] = []
    for scenario in data["scenarios"]:
        for command in scenario["commands"]:
            command["latency"] = summarize(command["samples_ms"]).as_dict()
        pty = scenario.get("extra", {}).get("pty")
        if pty is None:
            continue
        for key in [k for k in pty if k.endswith("_ratios")]:
            variant = key.removesuffix("_ratios")
            ratios = sorted(pty[key])
            pty[f"{variant}_ratio_median"] = median(ratios)
            pty[f"{variant}_ratio_iqr"] = list(quartiles(ratios))
            pty[f"{variant}_ratio_spread"] = [ratios[0], ratios[-1]]
        for key in [k for k in pty if k.endswith("_over_minimal_iqr")]:
            values = pty.get(key.removesuffix("_iqr"))
            if values is None:
                left.append(f"{scenario['name']}: {key} (per-round values not stored)")
            else:
                pty[key] = list(quartiles(values))
    return left


def rederive_network(data: dict[str, Any]) -> list[str]:
    """Recompute a ``network_bench`` result in place."""
    data.update(network_figures(data["samples_ms"], data["batch"]))
    return []


def rederive(path: Path) -> list[str]:
    """Recompute ``path``'s figures and write it back; returns what could not be."""
    data = json.loads(path.read_text())
    if "scenarios" in data:
        left = rederive_bench(data)
    elif "samples_ms" in data and "batch" in data:
        left = rederive_network(data)
    else:
        raise SystemExit(f"{path}: no stored samples this script knows how to read")
    data["rederived"] = NOTE.format(version=STATS_VERSION) + (
        f"; not recomputed: {', '.join(left)}" if left else ""
    )
    if "scenarios" in data:
        path.write_text(_bench_text(stamped(data)))
    else:
        write_result(path, data, indent=None)
    return left


def _bench_text(data: dict[str, Any]) -> str:
    """Like ``arduinoio bench --json``: indented, each list of numbers on one line."""
    text = json.dumps(data, indent=1)
    number = r"-?[\d.eE+-]+"
    return (
        re.sub(
            rf"\[\s*({number}(?:,\s*{number})*)\s*\]",
            lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]",
            text,
        )
        + "\n"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("paths", type=Path, nargs="+")
    args = parser.parse_args()
    for path in args.paths:
        left = rederive(path)
        print(f"{path}: stats_version {STATS_VERSION}" + (f" (left: {left})" if left else ""))


if __name__ == "__main__":
    main()
