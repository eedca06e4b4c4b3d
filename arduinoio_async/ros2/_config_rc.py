"""The configuration keys of an RC receiver channel input (``type: rc``).

An ``rc`` input is a board pulse input (:meth:`Board.pulse_input`) published as
``std_msgs/Float32`` -1..1: ``low_us`` -> -1, ``centre_us`` -> 0, ``high_us`` -> +1
(clamped; a throttle channel sets ``centre_us`` to its low end and reads 0..1), NaN
once no pulse came for ``timeout_ms``.  Its own module so that the configuration's
parser (:mod:`._config`, near its size limit) only asks it for these values; it returns
the problem as words and the parser raises it with the entry's place.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["RC_KEYS", "rc_values"]

#: Each key and its default: a receiver's usual end points, loss after 5 missed frames.
RC_DEFAULTS = {"timeout_ms": 100, "low_us": 1000, "centre_us": 1500, "high_us": 2000}
RC_KEYS = frozenset(RC_DEFAULTS)


def rc_values(item: Mapping[str, Any], kind: str) -> tuple[dict[str, int], str | None]:
    """The entry's rc values (defaults filled in), or the first problem as ``key: words``."""
    if kind != "rc":
        stray = sorted(RC_KEYS & item.keys())
        return {}, (f"{stray[0]}: only an rc input takes {stray[0]!r}" if stray else None)
    values = {key: item.get(key, default) for key, default in RC_DEFAULTS.items()}
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int):
            return {}, f"{key}: {value!r} is not a whole number of {key.rsplit('_', 1)[1]}"
    if not 1 <= values["timeout_ms"] <= 0xFFFF:
        return {}, f"timeout_ms: {values['timeout_ms']} is not 1-65535"
    low, centre, high = values["low_us"], values["centre_us"], values["high_us"]
    if not 0 <= low <= centre < high <= 0xFFFF or low == high:
        return {}, f"low_us/centre_us/high_us: need low <= centre < high, got {low}/{centre}/{high}"
    return values, None
