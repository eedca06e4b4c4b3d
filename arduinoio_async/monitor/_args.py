"""What a control from the page names, and what the page shows when one is refused.

Kept apart from :mod:`._panel`: every view reads its arguments the same way, and the hub
turns any refusal into the one line the page shows.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import ArduinoIOError, UsageError
from ..protocol.pins import DigitalPin

__all__ = ["describe_error", "pin_arg"]


def pin_arg(args: Mapping[str, Any]) -> DigitalPin:
    """The control's ``pin`` as a digital pin (UsageError naming the value otherwise)."""
    name = str(args.get("pin", ""))
    try:
        return DigitalPin[name.upper()]
    except KeyError:
        raise UsageError(f"{name!r} is not a digital pin (D2-D13)") from None


def describe_error(exc: BaseException) -> str:
    """What the page shows for a refused control."""
    if isinstance(exc, ArduinoIOError):
        return str(exc)
    if isinstance(exc, KeyError):
        return f"missing field {exc}"
    return f"{type(exc).__name__}: {exc}"
