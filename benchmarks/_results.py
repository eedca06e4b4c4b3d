"""Writing result files: the command that made them, the statistics version, and merges.

Every file under ``benchmarks/results/`` says how to make it again (``command``) and which
definition of a percentile its figures follow (``stats_version``, see
:mod:`arduinoio_async.bench.stats`).  Some files collect keys from several benchmarks
(``link.json``: the transaction soak, the CRC soak and cost, the idle failsafe); those
merge their keys with :func:`merge_result`, which leaves every other key as it was and
locks the file, as two runs may end together.
"""

from __future__ import annotations

import fcntl
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from arduinoio_async.bench.stats import STATS_VERSION

__all__ = [
    "LINK_JSON",
    "RESULTS",
    "command_line",
    "merge_result",
    "report",
    "stamped",
    "write_result",
]

RESULTS = Path(__file__).resolve().parent / "results"
#: The line-fault figures several benchmarks contribute keys to.
LINK_JSON = RESULTS / "link.json"


def command_line(argv: list[str] | None = None) -> str:
    """How this run was started, as ``.venv/bin/python -m benchmarks.NAME ARGS``."""
    spec = sys.modules["__main__"].__spec__
    module = spec.name if spec is not None else Path(sys.argv[0]).stem
    return " ".join([".venv/bin/python", "-m", module, *(sys.argv[1:] if argv is None else argv)])


def stamped(result: dict[str, Any]) -> dict[str, Any]:
    """``result`` with ``stats_version`` right after ``command`` (first if none)."""
    out: dict[str, Any] = {}
    if "command" in result:
        out["command"] = result["command"]
    out["stats_version"] = STATS_VERSION
    out.update((key, value) for key, value in result.items() if key != "stats_version")
    return out


def write_result(path: Path, result: dict[str, Any], *, indent: int | None = 1) -> None:
    """Write ``result`` (stamped with ``stats_version``) to ``path`` as JSON (``indent``
    None: compact, for files of raw samples)."""
    separators = (",", ":") if indent is None else None
    text = json.dumps(stamped(result), indent=indent, separators=separators)
    path.write_text(text + "\n")


def report(result: dict[str, Any], path: Path | None, *, indent: int | None = 2) -> None:
    """Print ``result`` and, when ``path`` is given (``--json``), write it there."""
    print(json.dumps(result, indent=2))
    if path is not None:
        write_result(path, result, indent=indent)


def merge_result(path: Path, update: Callable[[dict[str, Any]], None]) -> None:
    """Read ``path`` (a missing or empty file is ``{}``), let ``update`` change its keys
    in place, stamp it and write it back, all under an exclusive lock on the file."""
    with open(path, "a+") as file:
        fcntl.flock(file, fcntl.LOCK_EX)
        file.seek(0)
        text = file.read()
        data: dict[str, Any] = json.loads(text) if text.strip() else {}
        update(data)
        file.seek(0)
        file.truncate()
        file.write(json.dumps(stamped(data), indent=2) + "\n")
