"""Handing work from Zenoh's threads to the event loop, never blocking Zenoh's thread.

Zenoh runs subscriber, queryable and reply callbacks in its own threads.  Those threads
must not wait for the event loop (a loop that is closing would never answer, and Zenoh's
undeclare waits for running callbacks: a deadlock), so a callback only *schedules* a
function on the loop and returns.  On asyncio that is ``loop.call_soon_threadsafe``, on
trio ``TrioToken.run_sync_soon``; both keep the order in which items were scheduled.
Once the loop is gone, scheduling is a silent no-op: there is nobody left to tell.
"""

from __future__ import annotations

import asyncio
import importlib
from collections.abc import Callable
from typing import Any, TypeVar

import zenoh

__all__ = ["LoopHandle", "zenoh_callback"]

T = TypeVar("T")


class LoopHandle:
    """The running event loop, captured in it, callable from any thread."""

    __slots__ = ("_schedule",)

    def __init__(self) -> None:
        """Capture the current loop; must be called inside the event loop."""
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # not asyncio: anyio's only other backend is trio
            token: Any = importlib.import_module("trio.lowlevel").current_trio_token()
            self._schedule: Callable[..., Any] = token.run_sync_soon
        else:
            self._schedule = loop.call_soon_threadsafe

    def call_soon(self, func: Callable[..., object], *args: object) -> None:
        """Run ``func(*args)`` in the loop soon; FIFO; never blocks; no-op once closed."""
        # On every round trip, in Zenoh's thread: a bare try costs nothing, a
        # contextlib.suppress() is an object and two calls.
        try:  # noqa: SIM105
            self._schedule(func, *args)
        except RuntimeError:  # asyncio: the loop is closed; trio: RunFinishedError
            pass

    def forward(self, func: Callable[[T], object]) -> zenoh.handlers.Callback[T]:
        """A Zenoh handler that runs ``func(item)`` in the loop for each item, in order."""
        schedule = self._schedule

        def on_item(item: T) -> None:
            try:  # noqa: SIM105  (as in call_soon, one call less)
                schedule(func, item)
            except RuntimeError:
                pass

        return zenoh_callback(on_item)


def zenoh_callback(
    func: Callable[[T], object], drop: Callable[[], object] | None = None
) -> zenoh.handlers.Callback[T]:
    """A Zenoh callback handler that runs ``func`` on the thread that received the data.

    Not on a thread of its own (Zenoh's default): our callbacks only schedule, and one
    receiving thread keeps the order in which a link delivered replies and publications.
    """
    return zenoh.handlers.Callback(func, drop, indirect=False)
