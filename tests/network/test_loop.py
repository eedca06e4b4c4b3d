"""LoopHandle: Zenoh's threads hand items to the event loop, in order, in batches."""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable

import anyio
import pytest

from arduinoio_async.network._loop import LoopHandle

THREADS = 4
ITEMS = 2000


def count_wake_ups(handle: LoopHandle) -> list[int]:
    """Make ``handle`` count the times it wakes its loop (in the returned one-item list)."""
    wakes = [0]
    schedule = handle._schedule

    def counting(callback: Callable[[], None]) -> object:
        wakes[0] += 1
        return schedule(callback)

    handle._schedule = counting
    return wakes


async def test_items_from_many_threads_all_run_each_threads_in_order() -> None:
    handle = LoopHandle()
    wakes = count_wake_ups(handle)
    seen: list[tuple[int, int]] = []
    all_ran = anyio.Event()

    def record(thread: int, n: int) -> None:
        seen.append((thread, n))
        if len(seen) == THREADS * ITEMS:
            all_ran.set()

    def produce(thread: int) -> None:
        for n in range(ITEMS):
            handle.call_soon(record, thread, n)

    async with anyio.create_task_group() as tg:
        for thread in range(THREADS):
            tg.start_soon(anyio.to_thread.run_sync, produce, thread)
        for n in range(ITEMS):  # the loop's own thread schedules too
            handle.call_soon(record, THREADS, n)
            if n % 100 == 0:
                await anyio.lowlevel.checkpoint()
    with anyio.fail_after(10):
        await all_ran.wait()
    assert len(seen) == (THREADS + 1) * ITEMS  # nothing lost, nothing run twice
    for thread in range(THREADS + 1):
        assert [n for t, n in seen if t == thread] == list(range(ITEMS))
    assert 1 <= wakes[0] <= len(seen)


async def test_items_scheduled_before_the_loop_takes_them_share_one_wake_up() -> None:
    handle = LoopHandle()
    wakes = count_wake_ups(handle)
    ran: list[int] = []
    batch_ran = anyio.Event()
    for n in range(100):
        handle.call_soon(ran.append, n)
    handle.call_soon(batch_ran.set)
    assert ran == [] and wakes[0] == 1  # nothing runs before the loop gets to it
    with anyio.fail_after(5):
        await batch_ran.wait()
    assert ran == list(range(100))
    later = anyio.Event()
    handle.call_soon(later.set)  # the batch was taken: the next item wakes the loop again
    assert wakes[0] == 2
    with anyio.fail_after(5):
        await later.wait()


async def test_a_failing_item_is_logged_and_the_rest_of_its_batch_runs(
    caplog: pytest.LogCaptureFixture,
) -> None:
    handle = LoopHandle()
    ran: list[int] = []
    done = anyio.Event()

    def fail() -> None:
        raise ValueError("a callback's bug")

    handle.call_soon(ran.append, 1)
    handle.call_soon(fail)
    handle.call_soon(ran.append, 2)
    handle.call_soon(done.set)
    with caplog.at_level(logging.ERROR, logger="arduinoio_async.network._loop"):
        with anyio.fail_after(5):
            await done.wait()
    assert ran == [1, 2]
    assert any("a callback's bug" in (r.exc_text or "") for r in caplog.records)


def test_scheduling_after_the_loop_closed_is_a_no_op() -> None:
    async def capture() -> LoopHandle:
        return LoopHandle()

    handle = asyncio.run(capture())
    handle.call_soon(print, "never")  # no loop to run it, and no exception either
    forwarded: list[object] = []
    handle.forward(forwarded.append)  # a handler can still be made; it is never run


def test_trio_gets_its_items_in_order() -> None:
    trio = pytest.importorskip("trio")

    async def main() -> list[int]:
        handle = LoopHandle()
        got: list[int] = []
        done = trio.Event()

        def produce() -> None:
            for n in range(500):
                handle.call_soon(got.append, n)
            handle.call_soon(done.set)

        thread = threading.Thread(target=produce)
        thread.start()
        with trio.fail_after(5):
            await done.wait()
        await trio.to_thread.run_sync(thread.join)
        return got

    assert trio.run(main) == list(range(500))
