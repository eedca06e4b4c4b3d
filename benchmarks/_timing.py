"""Pauses for sequential latency benchmarks."""

from __future__ import annotations

import time

import anyio.lowlevel

__all__ = ["blocking_pause"]


async def blocking_pause(seconds: float) -> None:
    """Pause between sequential requests so the next one meets the 16U2 model's tick at
    a random phase.

    ``time.sleep``, not ``anyio.sleep``: the event loop's timers have 1 ms granularity
    (epoll), which would quantise the phase against the bridge's 4.096 ms tick and its
    1 ms USB frames.  Only for loops that run nothing else between requests.
    """
    time.sleep(seconds)  # noqa: ASYNC251
    await anyio.lowlevel.checkpoint()
