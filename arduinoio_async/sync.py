"""Deprecated: the blocking API is :mod:`arduinoio_async.blocking` now.

``sync`` read as "link synchronisation" to newcomers; the old import path keeps working
(every name is the same object) and warns once, on import.
"""

from __future__ import annotations

import warnings

from .blocking import *  # noqa: F403
from .blocking import __all__ as __all__

warnings.warn(
    "arduinoio_async.sync is deprecated: import arduinoio_async.blocking instead",
    DeprecationWarning,
    stacklevel=2,
)
