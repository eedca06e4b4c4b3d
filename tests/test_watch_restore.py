"""Watches across a reset of the board, on the fake board: restored, counted, or ended.

Two kinds of reset: the host's ``board.reset(restore=True)`` (the watchdog reset the Reset
request asks for), and a reset by itself (``fake.reboot()``: power loss, brown-out, the
reset button) that the manager notices and restores with ``board.adopt(link)``.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import A0, A1, D2, D3, D4, D5, D6, D7
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.changes import AnalogChanges, Change, ChangeStream
from arduinoio_async.errors import UsageError, WatchLostError
from arduinoio_async.testing import FakeBoard

from .fake_boards import connected

pytestmark = pytest.mark.anyio

Reset = Callable[[Board, FakeBoard], Awaitable[None]]


async def host_reset(board: Board, fake: FakeBoard) -> None:
    await board.reset(restore=True)


async def reset_by_itself(board: Board, fake: FakeBoard) -> None:
    fake.reboot()
    await board.adopt(board.link)  # what the manager does when its heartbeat sees it


RESETS = [pytest.param(host_reset, id="board.reset"), pytest.param(reset_by_itself, id="reboot")]


async def next_changes(changes: ChangeStream, count: int) -> list[Change]:
    with anyio.fail_after(2):
        return [await anext(changes) for _ in range(count)]


@pytest.mark.parametrize("reset", RESETS)
async def test_a_change_watch_keeps_delivering_and_the_restart_is_no_gap(reset: Reset) -> None:
    async with connected() as (board, fake), board.gpio(D3).watch() as changes:
        for level in (True, False, True):
            fake.drive(3, level)
        before = await next_changes(changes, 3)
        await reset(board, fake)
        assert fake.change_sequence == 0 and fake.role(3) == "input"  # restored, fresh count
        fake.levels[3] = False  # the fresh boot reads the pin low
        for level in (True, False):
            fake.drive(3, level)
        after = await next_changes(changes, 2)
    assert [c.sequence for c in before] == [0, 1, 2]
    assert [(c.sequence, c.level) for c in after] == [(0, True), (1, False)]
    assert changes.restarts == 1
    assert changes.gaps == changes.lost == 0  # not 65,533 events "lost" to the restart
    fake.drive(3, True)  # the block's end unsubscribed the restored watch
    assert fake.change_sequence == 2


@pytest.mark.parametrize("reset", RESETS)
async def test_a_counter_report_watch_keeps_reporting_from_the_fresh_count(reset: Reset) -> None:
    async with connected() as (board, fake):
        counter = await board.counter(D2)
        async with counter.reports(every=3) as reports:
            for _ in range(7):
                fake.drive(2, True)
                fake.drive(2, False)
            with anyio.fail_after(2):
                before = [await anext(reports), await anext(reports)]
            await reset(board, fake)
            for _ in range(6):
                fake.drive(2, True)
                fake.drive(2, False)
            with anyio.fail_after(2):
                after = [await anext(reports), await anext(reports)]
        assert [r.count for r in before] == [3, 6]
        assert [r.count for r in after] == [3, 6]  # the board counts from 0 after its boot
        assert reports.missed == reports.dropped == 0
        assert reports.restarts == 1
        assert await counter.read() == 6


@pytest.mark.parametrize("reset", RESETS)
async def test_an_analog_watch_keeps_delivering_from_the_restored_baseline(reset: Reset) -> None:
    async with connected() as (board, fake), board.analog(A0).watch(deadband=10) as moves:
        assert isinstance(moves, AnalogChanges) and moves.baseline == 0
        fake.set_analog(0, 100)
        with anyio.fail_after(2):
            assert (await anext(moves)).sequence == 0
        fake.analog[0] = 500  # moved while the board was resetting: nobody was watching
        await reset(board, fake)
        assert moves.baseline == 500  # the restore's measurement
        fake.set_analog(0, 505)  # within the deadband of the new baseline: no report
        fake.set_analog(0, 600)
        with anyio.fail_after(2):
            move = await anext(moves)
    assert (move.value, move.sequence) == (600, 0)
    assert moves.restarts == 1 and moves.lost == 0


async def test_a_restore_the_board_refuses_ends_the_iterator_with_watch_lost_error() -> None:
    async with connected() as (board, fake):
        gpio = board.gpio(D3)
        with pytest.raises(WatchLostError) as lost:
            async with gpio.watch() as changes:
                fake.drive(3, True)
                with anyio.fail_after(2):
                    await anext(changes)
                await gpio.write(False)  # another role meanwhile: the board ends the watch
                fake.reboot()
                await board.adopt(board.link)  # roles restored (D3 an output), watch refused
                with anyio.fail_after(2):
                    async for _change in changes:
                        pytest.fail("no change can come from an output")
        assert isinstance(lost.value.request, p.GpioWatch)
        assert "the pin is not set up for that" in lost.value.reason
        assert "the request to report every change of D3 could not" in str(lost.value)
        assert len(board.watches) == 0
        assert fake.role(3) == "output" and await board.read_id() == board.board_id


async def test_a_callback_watch_whose_restore_is_refused_logs_and_raises_at_its_end(
    caplog: pytest.LogCaptureFixture,
) -> None:
    seen: list[Change] = []
    async with connected() as (board, _fake):
        gpio = board.gpio(D3)
        with pytest.raises(WatchLostError):
            async with gpio.on_change(seen.append):
                await gpio.write(True)
                await board.reset(restore=True)
        assert any(
            r.levelno == logging.ERROR and "could not be restored" in r.getMessage()
            for r in caplog.records
        )
        assert seen == [] and len(board.watches) == 0


async def test_many_concurrent_watches_all_survive_a_reset() -> None:
    pins = (D3, D4, D5, D6, D7)
    async with connected() as (board, fake):
        watching = 2 * len(pins)  # two blocks per pin share one board subscription
        ready = anyio.Event()
        halfway = anyio.Event()
        got: dict[int, list[bool]] = {}

        async def follow(pin: int, key: int) -> None:
            nonlocal watching
            async with board.gpio(pins[pin]).watch() as changes:
                watching -= 1
                if not watching:
                    ready.set()
                levels = got.setdefault(key, [])
                async for change in changes:
                    levels.append(change.level)
                    if sum(len(levels) for levels in got.values()) == 2 * 2 * len(pins):
                        halfway.set()
                    if len(levels) == 4:
                        assert changes.restarts == 1 and changes.gaps == 0
                        return

        async def drive_all() -> None:
            for pin in pins:
                fake.drive(int(pin), True)
                fake.drive(int(pin), False)

        with anyio.fail_after(5):
            async with anyio.create_task_group() as tg:
                for key in range(2 * len(pins)):
                    tg.start_soon(follow, key % len(pins), key)
                await ready.wait()
                assert len(board.watches) == len(pins)
                await drive_all()
                await halfway.wait()  # each block has its two changes from before the reset
                await board.reset(restore=True)
                for pin in pins:
                    fake.levels[int(pin)] = False
                await drive_all()
        assert got == {key: [True, False, True, False] for key in range(2 * len(pins))}
        assert len(board.watches) == 0


async def test_a_watch_cancelled_during_the_restore_leaves_no_subscription_on_the_board() -> None:
    async with connected() as (board, fake):
        d3 = await board.digital_input(D3)
        async with board.gpio(D4).watch() as d4_changes:  # stays through the reset
            inside = anyio.Event()
            scope = anyio.CancelScope()
            restored = anyio.Event()

            async def watch_d3() -> None:
                with scope:
                    async with d3.watch():
                        inside.set()
                        await anyio.sleep_forever()

            async def adopt() -> None:
                await board.adopt(board.link)
                restored.set()

            async with anyio.create_task_group() as tg:
                tg.start_soon(watch_d3)
                await inside.wait()
                fake.reboot()
                tg.start_soon(adopt)
                with anyio.fail_after(2):
                    while not board.watches._lock.locked():  # the restore is under way
                        await anyio.lowlevel.checkpoint()
                scope.cancel()
                with anyio.fail_after(2):
                    await restored.wait()
            assert board.watches.requests() == [p.GpioWatch(D4, True)]
            fake.drive(3, True)
            assert fake.change_sequence == 0  # D3 is no longer watched on the board
            fake.drive(4, True)
            with anyio.fail_after(2):
                change = await anext(d4_changes)
        assert (change.pin, change.sequence, d4_changes.restarts) == (4, 0, 1)
        assert len(board.watches) == 0
        assert await board.read_id() == board.board_id


async def test_replaying_the_roles_without_a_reset_keeps_the_watches() -> None:
    """A replayed set-up ends the pin's subscription on the board (GPIO CONFIG, COUNTER
    CONFIG): ``board.restore()`` and re-arming the failsafe subscribe again, no restart."""
    async with connected() as (board, fake):
        counter = await board.counter(D2)
        led = await board.digital_output(D5)
        await board.arm_failsafe(1000, {led: False})
        counts = []
        async with board.gpio(D3).watch() as changes, counter.reports(every=2) as reports:
            for again in (board.restore, fake.expire_failsafe, board.rearm_failsafe, None):
                fake.drive(3, not fake.levels[3])
                for _ in range(2):
                    fake.drive(2, True)
                    fake.drive(2, False)
                with anyio.fail_after(2):
                    await anext(changes)
                    counts.append((await anext(reports)).count)
                if again is not None:
                    await again()
        assert counts == [2, 2, 4, 2]  # a replayed counter set-up counts from 0; a trip not
        assert changes.received == 4 and changes.restarts == changes.gaps == 0
        assert reports.received == 4 and reports.missed == reports.restarts == 0


@pytest.mark.parametrize("reset", RESETS)
async def test_a_stream_keeps_sampling_after_the_restore_and_the_restart_is_no_gap(
    reset: Reset,
) -> None:
    async with connected() as (board, fake):
        fake.analog[0] = 123
        async with board.stream(analog=[A0], period_ms=5) as samples:
            with anyio.fail_after(2):
                before = [await anext(samples) for _ in range(3)]
            await reset(board, fake)
            assert fake.stream.running and fake.stream.request == p.StreamStart(
                0b1, p.StreamFlags.NONE, 5000
            )
            with anyio.fail_after(2):
                after = await anext(samples)
                while after.sequence != 0:  # samples of the old boot still buffered
                    after = await anext(samples)
        assert not fake.stream.running  # the block's end stopped the restored stream
    assert before[0].sequence < before[1].sequence < before[2].sequence
    assert after.analog[A0] == 123
    assert samples.restarts == 1
    # the fake skips a number when the host is slow to read (a few at most); neither the
    # restart (numbers from 0 again) nor the stop may count a false gap of ~65,000
    assert samples.gaps < 20


async def test_the_board_runs_one_stream_shared_by_blocks_with_the_same_layout() -> None:
    async with connected() as (board, fake):
        fake.analog[0] = 321
        async with (
            board.stream(analog=[A0], period_ms=2) as first,
            board.stream(analog=[A0], period_ms=2) as second,
        ):
            with anyio.fail_after(2):
                shared = await anext(second)
                # the first block subscribed earlier: it has every sample the second has
                mine = await anext(first)
                while mine.sequence != shared.sequence:
                    mine = await anext(first)
            assert mine.analog[A0] == shared.analog[A0] == 321
            with pytest.raises(UsageError, match="already streams analog A0 every 2000 us"):
                async with board.stream(analog=[A0, A1], period_ms=2):
                    pass
            assert fake.stream.request == p.StreamStart(0b1, p.StreamFlags.NONE, 2000)
            assert fake.stream.running  # the refused block stopped nothing
        assert not fake.stream.running  # the last block to end stopped it


async def test_many_tasks_start_and_end_the_same_stream_at_once() -> None:
    async with connected() as (board, fake):
        got: list[int] = []

        async def reader(cancel_early: bool) -> None:
            with anyio.CancelScope() as scope:
                async with board.stream(analog=[A0], period_ms=2) as samples:
                    if cancel_early:
                        scope.cancel()
                        await anyio.lowlevel.checkpoint()
                    for _ in range(3):
                        got.append((await anext(samples)).sequence)

        with anyio.fail_after(5):
            async with anyio.create_task_group() as tg:
                for i in range(10):
                    tg.start_soon(reader, i % 3 == 0)  # some blocks cancelled at once
        assert len(got) == 3 * 6  # every block that was not cancelled got its samples
        assert not fake.stream.running  # the last one out stopped it
        assert len(board.watches) == 0
