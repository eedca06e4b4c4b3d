"""Handing work from Zenoh's threads to the event loop, never blocking Zenoh's thread.

Zenoh runs subscriber, queryable and reply callbacks in its own threads.  Those threads
must not wait for the event loop (a loop that is closing would never answer, and Zenoh's
undeclare waits for running callbacks: a deadlock), so a callback only *schedules* a
function on the loop and returns.  On asyncio that is ``loop.call_soon_threadsafe``, on
trio ``TrioToken.run_sync_soon``.  Once the loop is gone, scheduling is a silent no-op:
there is nobody left to tell.

Items go over in batches: the first one of a batch wakes the loop, and items scheduled
while that wake-up is still pending join the batch without another one.  A wake-up is a
system call (asyncio writes to its self-pipe, letting go of the interpreter lock
meanwhile); replies to pipelined requests arrive in bursts, and a burst then costs one
wake-up instead of one per reply (pipelined remote ``read_id`` 2-8 % faster in four A/B
runs, see docs/network.md, "How fast").  A lone item costs what a direct
``call_soon_threadsafe`` costs, plus an uncontended lock.
"""

from __future__ import annotations

import asyncio
import collections
import importlib
import logging
import threading
from collections.abc import Callable
from typing import Any, TypeVar

import zenoh

__all__ = ["LoopHandle", "zenoh_callback"]

log = logging.getLogger(__name__)

T = TypeVar("T")

_Item = tuple[Callable[..., object], tuple[object, ...]]


class LoopHandle:
    """The running event loop, captured in it, callable from any thread.

    Everything scheduled through one handle runs in the loop in the order it was
    scheduled (from several threads: the order in which they took the handle's lock).
    """

    __slots__ = ("_lock", "_pending", "_schedule", "_waking")

    def __init__(self) -> None:
        """Capture the current loop; must be called inside the event loop."""
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # not asyncio: anyio's only other backend is trio
            token: Any = importlib.import_module("trio.lowlevel").current_trio_token()
            self._schedule: Callable[[Callable[[], None]], object] = token.run_sync_soon
        else:
            self._schedule = loop.call_soon_threadsafe
        self._lock = threading.Lock()  # held for a few operations, never across a call
        self._pending: collections.deque[_Item] = collections.deque()
        self._waking = False  # a wake-up is scheduled and has not taken the batch yet

    def call_soon(self, func: Callable[..., object], *args: object) -> None:
        """Run ``func(*args)`` in the loop soon; FIFO; never waits for the loop; a no-op
        once the loop is closed.  An exception ``func`` raises is logged."""
        with self._lock:
            self._pending.append((func, args))
            if self._waking:
                return  # the pending wake-up takes this item along
            self._waking = True
        # On every round trip, in Zenoh's thread: a bare try costs nothing, a
        # contextlib.suppress() is an object and two calls.
        try:  # noqa: SIM105
            self._schedule(self._run_batch)
        except RuntimeError:  # asyncio: the loop is closed; trio: RunFinishedError
            pass

    def forward(self, func: Callable[[T], object]) -> zenoh.handlers.Callback[T]:
        """A Zenoh handler that runs ``func(item)`` in the loop for each item, in order."""
        call_soon = self.call_soon

        def on_item(item: T) -> None:
            call_soon(func, item)

        return zenoh_callback(on_item)

    def _run_batch(self) -> None:
        """In the loop: run every item scheduled so far; later ones make a new batch."""
        with self._lock:
            self._waking = False
            batch, self._pending = self._pending, collections.deque()
        for func, args in batch:
            try:
                func(*args)
            except Exception:  # one failing item must not drop the rest of its batch
                log.exception("%r failed in the event loop", func)


def zenoh_callback(
    func: Callable[[T], object], drop: Callable[[], object] | None = None
) -> zenoh.handlers.Callback[T]:
    """A Zenoh callback handler that runs ``func`` on the thread that received the data.

    Not on a thread of its own (Zenoh's default): our callbacks only schedule, and one
    receiving thread keeps the order in which a link delivered replies and publications.
    """
    return zenoh.handlers.Callback(func, drop, indirect=False)
