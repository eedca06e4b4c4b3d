"""The configuration keys of a stepper output (``type: stepper``).

A stepper output takes ``max_speed`` (1-10,000 steps/s), ``acceleration``
(1-1,000,000 steps/s^2) and ``steps_per_rev`` (a positive number: the position topic is
in radians).  Its own module, as :mod:`._config_rc`, so that the configuration's parser
(:mod:`._config`, at its size limit) only asks it for these values; it returns the problem
as ``key: words`` and the parser raises it with the entry's place.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["stepper_values"]

#: Each whole-number key and its largest value.
_WHOLE = (("max_speed", 10_000), ("acceleration", 1_000_000))


def stepper_values(item: Mapping[str, Any], kind: str) -> tuple[dict[str, Any], str | None]:
    """The entry's stepper options (only those given), or the first problem."""
    options: dict[str, Any] = {}
    for key, top in _WHOLE:
        if key not in item:
            continue
        if kind != "stepper":
            return {}, f"{key}: only a stepper takes {key}"
        value = item[key]
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= top:
            return {}, f"{key}: {value!r} is not a whole number 1-{top:,}"
        options[key] = value
    if "steps_per_rev" in item:
        if kind != "stepper":
            return {}, "steps_per_rev: only a stepper takes steps_per_rev"
        value = item["steps_per_rev"]
        if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
            return {}, f"steps_per_rev: {value!r} is not a positive number"
        options["steps_per_rev"] = float(value)
    return options, None
