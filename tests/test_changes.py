"""Input change events on the fake board: subscription, order, loss accounting, callbacks."""

from __future__ import annotations

import contextlib
import logging

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import D2, D3, D5, D7
from arduinoio_async import protocol as p
from arduinoio_async.board.changes import Change
from arduinoio_async.errors import BoardError, UsageError

from .fake_boards import connected

pytestmark = pytest.mark.anyio


async def test_the_fake_board_announces_change_events() -> None:
    async with connected() as (board, _fake):
        assert board.capabilities.features & p.Feature.GPIO_CHANGES


async def test_changes_arrive_in_order_with_level_edge_and_sequence() -> None:
    async with connected() as (board, fake):
        got: list[Change] = []
        async with board.gpio(D3).watch() as changes:
            assert fake.role(3) == "input"
            for level in (True, False, True, True, False):  # one repeat: no change
                fake.drive(3, level)
            with anyio.fail_after(2):
                async for change in changes:
                    got.append(change)
                    if len(got) == 4:
                        break
        assert [(c.pin, c.level, c.rose) for c in got] == [
            (3, True, True),
            (3, False, False),
            (3, True, True),
            (3, False, False),
        ]
        assert [c.sequence for c in got] == [0, 1, 2, 3]
        assert changes.gaps == changes.dropped == 0
        # the block unsubscribed: no further event reaches the link
        fake.drive(3, True)
        assert (await board.gpio(D3).read()).rose  # the READ latch still works


async def test_a_changes_loop_and_the_callback_form() -> None:
    async with connected() as (board, fake):
        seen: list[bool] = []
        done = anyio.Event()

        def callback(change: Change) -> None:
            seen.append(change.level)
            if len(seen) == 3:
                done.set()

        async with board.gpio(D5).on_change(callback):
            for level in (True, False, True):
                fake.drive(5, level)
            with anyio.fail_after(2):
                await done.wait()
        assert seen == [True, False, True]

        gen = board.gpio(D7).changes()
        async with contextlib.aclosing(gen):
            first = anyio.Event()

            async def toggle() -> None:
                while not first.is_set():
                    fake.drive(7, not fake.levels[7])
                    await anyio.sleep(0.001)

            async with anyio.create_task_group() as tg:
                tg.start_soon(toggle)
                with anyio.fail_after(2):
                    change = await gen.__anext__()
                first.set()
        assert change.pin == 7


async def test_a_failing_callback_is_logged_and_the_link_keeps_working(
    caplog: pytest.LogCaptureFixture,
) -> None:
    called = anyio.Event()

    def broken(change: Change) -> None:
        called.set()
        raise RuntimeError("user bug")

    async with connected() as (board, fake), board.gpio(D3).on_change(broken):
        fake.drive(3, True)
        with anyio.fail_after(2):
            await called.wait()
        assert board.capabilities == await board.request(p.ReadCapabilities())
    assert any("user bug" in str(r.exc_info) for r in caplog.records if r.exc_info)
    assert any(r.levelno == logging.ERROR for r in caplog.records)


async def test_loss_on_the_board_is_a_gap_and_a_slow_consumer_drops_the_oldest() -> None:
    arrived: list[Change] = []
    all_arrived = anyio.Event()

    def count(change: Change) -> None:
        arrived.append(change)
        if len(arrived) == 4:
            all_arrived.set()

    async with connected() as (board, fake):
        async with board.gpio(D3).watch(buffer=2) as changes:
            # a second watcher of the same pin: its end must not end the first's events
            async with board.gpio(D3).on_change(lambda change: None):
                pass
            async with board.gpio(D3).on_change(count):
                fake.drive(3, True)
                with anyio.fail_after(2):
                    first = await changes.__anext__()
                fake.change_sequence += 5  # five events the board could not send
                for level in (False, True, False):
                    fake.drive(3, level)
                with anyio.fail_after(2):
                    await all_arrived.wait()
            rest = [await changes.__anext__(), await changes.__anext__()]
        assert first.sequence == 0
        assert changes.gaps == 5
        assert changes.dropped == 1  # the buffer of 2 kept the newest two
        assert [c.level for c in rest] == [True, False]
        assert changes.lost == 6


async def test_watching_needs_an_input_and_many_tasks_can_watch_at_once() -> None:
    async with connected() as (board, fake):
        await board.digital_output(D5)
        with pytest.raises(BoardError) as refused:
            await board.request(p.GpioWatch(5, True))
        assert refused.value.code is p.ErrorCode.PIN_NOT_CONFIGURED
        counts: dict[int, int] = {}

        async def consume(pin: int) -> None:
            async with board.gpio(pin_of[pin]).watch() as changes:
                ready.set()
                async for change in changes:
                    counts[change.pin] = counts.get(change.pin, 0) + 1
                    if counts[change.pin] == 10:
                        return

        pin_of = {3: D3, 7: D7}
        async with anyio.create_task_group() as tg:
            for pin in pin_of:
                ready = anyio.Event()
                tg.start_soon(consume, pin)
                await ready.wait()
            for _ in range(10):
                for pin in pin_of:
                    fake.drive(pin, not fake.levels[pin])
                await anyio.lowlevel.checkpoint()
        assert counts == {3: 10, 7: 10}


async def test_a_watched_counter_reports_every_n_counts() -> None:
    async with connected() as (board, fake):
        counter = await board.counter(D2, edge=p.Edge.RISING)
        with pytest.raises(BoardError):
            await board.request(p.CounterWatch(3, 5))  # D3 is no counter
        async with counter.reports(every=3) as reports:
            for _ in range(7):
                fake.drive(2, True)
                fake.drive(2, False)
            with anyio.fail_after(2):
                got = [await reports.__anext__(), await reports.__anext__()]
        assert [r.count for r in got] == [3, 6]
        assert reports.missed == reports.dropped == 0
        fake.drive(2, True)  # the block ended the watch: no report follows
        assert await counter.read() == 8
        assert reports.received == 2


async def test_report_blocks_of_one_counter_share_the_board_watch_and_one_interval() -> None:
    async with connected() as (board, fake):
        counter = await board.counter(D2)
        async with counter.reports(every=2) as outer:
            async with counter.reports(every=2):
                pass  # its end must not end the outer block's reports
            with pytest.raises(UsageError, match="every 2 counts"):
                async with counter.reports(every=3):
                    pass
            for _ in range(2):
                fake.drive(2, True)
                fake.drive(2, False)
            with anyio.fail_after(2):
                assert (await anext(outer)).count == 2
        assert len(board.watches) == 0
