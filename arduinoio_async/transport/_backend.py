"""Which event loop to run on: uvloop when it is installed (the ``uvloop`` extra).

The library works on any anyio backend (asyncio, uvloop, trio); the transport's fast path
(decoding in the fd-readable callback) is asyncio's, and uvloop makes that loop cheaper.
Programs that own their event loop choose it themselves; :func:`run` is the default for
the command line and the benchmarks.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Awaitable, Callable
from typing import Any, TypeVar

import anyio

__all__ = ["backend_options", "run"]

T = TypeVar("T")


def backend_options(*, uvloop: bool | None = None) -> dict[str, Any]:
    """anyio's asyncio backend options: uvloop if installed (or as ``uvloop`` says)."""
    if uvloop is None:
        uvloop = importlib.util.find_spec("uvloop") is not None
    return {"use_uvloop": bool(uvloop)}


def run(func: Callable[..., Awaitable[T]], *args: Any, uvloop: bool | None = None) -> T:
    """``anyio.run(func, *args)`` on asyncio, with uvloop when it is installed."""
    return anyio.run(func, *args, backend="asyncio", backend_options=backend_options(uvloop=uvloop))
