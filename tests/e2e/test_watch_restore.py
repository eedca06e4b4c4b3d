"""Watches across a reset of the virtual Uno: a change watch, a counter report watch and an
analog deadband watch run at once, and each keeps delivering after the reset.

Two resets: the harness's power-on reset behind the host's back (the manager's heartbeat
notices the fresh boot and restores roles, then watches), and the watchdog reset the host
asks for with ``board.reset(restore=True)``.  The oracles are the fixture: the pulses it
generates, the voltage it sets (read back with ANALOG READ), the level it drives.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import AsyncExitStack, asynccontextmanager
from dataclasses import dataclass

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import A0, D2, D3, D4, D5, D6, D7, D8
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.changes import AnalogChanges, ChangeStream, CountReports
from arduinoio_async.errors import WatchLostError
from arduinoio_async.manager import BoardManager
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.sim.virtual_uno import VirtualUno

from ..fake_boards import reset_event

pytestmark = pytest.mark.sim

COUNT_MV = 5000 / 1024


def mv(counts: int) -> float:
    return (counts + 0.5) * COUNT_MV


@dataclass
class Watched:
    changes: ChangeStream
    reports: CountReports
    moves: AnalogChanges


@asynccontextmanager
async def three_watches(board: Board) -> AsyncIterator[Watched]:
    """D3 change events, D2 counter reports every 5 counts, A0 moves past 40 counts."""
    counter = await board.counter(D2)
    async with AsyncExitStack() as stack:
        changes = await stack.enter_async_context(board.gpio(D3).watch())
        reports = await stack.enter_async_context(counter.reports(every=5))
        moves = await stack.enter_async_context(board.analog(A0).watch(deadband=40))
        yield Watched(changes, reports, moves)


async def exercise(uno: VirtualUno, board: Board, watched: Watched, analog: int) -> None:
    """One rise and fall of D3, ten counts on D2, A0 to ``analog``: each watch reports."""
    # Each level is driven once the board saw the previous one: two drives in one slice
    # of a simulation that lags a loaded machine would make a pulse no interrupt sees.
    with anyio.fail_after(10):
        await uno.drive("D3", 1)
        rise = await anext(watched.changes)
        await uno.drive("D3", 0)
        fall = await anext(watched.changes)
    await uno.pulses("D2", count=10, high_us=200, low_us=300)
    await uno.set_analog(0, mv(analog))
    with anyio.fail_after(10):
        first, second = await anext(watched.reports), await anext(watched.reports)
        move = await anext(watched.moves)
    assert (rise.level, fall.level, fall.sequence - rise.sequence) == (True, False, 1)
    assert (first.count, second.count) == (5, 10)
    assert move.value == await board.analog(A0).read()
    assert abs(move.value - analog) <= 1
    assert watched.changes.gaps == watched.moves.gaps == watched.reports.missed == 0


Reset = Callable[[VirtualUno, Board], Awaitable[None]]


async def check_restored(uno: VirtualUno, board: Board, reset: Reset) -> None:
    await uno.set_analog(0, mv(100))
    async with three_watches(board) as watched:
        await exercise(uno, board, watched, analog=400)
        assert (watched.changes.restarts, watched.reports.restarts) == (0, 0)
        await reset(uno, board)
        assert watched.changes.restarts == watched.reports.restarts == 1
        assert watched.moves.restarts == 1
        assert watched.moves.baseline is not None
        assert abs(watched.moves.baseline - 400) <= 1  # measured by the restore
        await exercise(uno, board, watched, analog=700)
        # the board numbers from 0 after its boot, and the queues knew it
        assert watched.changes.lost == watched.moves.lost == 0
    assert len(board.watches) == 0


async def test_watches_keep_delivering_after_a_power_on_reset_the_manager_restores(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=21)
    async with BoardManager(ports=[uno.port], rescan_interval=0.05) as boards:
        board = await boards.get(21)
        reset_seen = reset_event(boards)

        async def power_on_reset(uno: VirtualUno, board: Board) -> None:
            await uno.reset()
            with anyio.fail_after(10):
                await reset_seen.wait()  # the heartbeat saw the fresh boot: restoring
                await boards.wait_connected(21)  # the restore is complete

        await check_restored(uno, board, power_on_reset)


async def test_watches_keep_delivering_after_a_watchdog_reset(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=22)

    async def watchdog_reset(uno: VirtualUno, board: Board) -> None:
        await board.reset(restore=True)

    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await check_restored(uno, board, watchdog_reset)


async def test_a_watch_the_firmware_refuses_to_restore_ends_with_watch_lost_error(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=23)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        gpio = board.gpio(D3)
        with pytest.raises(WatchLostError) as lost:
            async with gpio.watch() as changes:
                await gpio.write(True)  # another role meanwhile
                await board.reset(restore=True)
                with anyio.fail_after(5):
                    async for _change in changes:
                        pytest.fail("an output reports no change")
        assert lost.value.request == p.GpioWatch(D3, True)
        assert "the pin is not set up for that" in lost.value.reason
        assert (await board.gpio(D3).read()).level is True  # the output role was restored


async def test_many_concurrent_watches_and_a_watch_cancelled_during_the_restore(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Ten blocks on five pins follow their changes through a watchdog reset, while an
    eleventh block (D8) is cancelled as the restore runs: the board then watches D8 no
    more (a D8 edge uses up no sequence number: the next D3 change has the next one)."""
    uno = await virtual_uno_factory(board_id=24)
    pins = (D3, D4, D5, D6, D7)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        got: dict[int, list[tuple[bool, int]]] = {key: [] for key in range(2 * len(pins))}
        progress = [anyio.Event()]  # set (and replaced) at every change a block receives

        async def until_each_has(count: int) -> None:
            while not all(len(levels) >= count for levels in got.values()):
                await progress[0].wait()

        entered = 0
        all_in = anyio.Event()
        d8_in = anyio.Event()
        d8_scope = anyio.CancelScope()

        async def follow(key: int) -> None:
            nonlocal entered
            async with board.gpio(pins[key % len(pins)]).watch() as changes:
                entered += 1
                if entered == len(got):
                    all_in.set()
                async for change in changes:
                    got[key].append((change.level, changes.restarts))
                    progress[0].set()
                    progress[0] = anyio.Event()
                    if len(got[key]) == 4:
                        assert changes.gaps == 0
                        return

        async def watch_d8() -> None:
            with d8_scope:
                async with board.gpio(D8).watch():
                    d8_in.set()
                    await anyio.sleep_forever()

        async def drive_all(before: int) -> None:
            """A rise then a fall on every pin, each once every block saw the one before."""
            for level in (1, 0):
                for pin in pins:
                    await uno.drive(pin.name, level)
                before += 1
                await until_each_has(before)

        async def cancel_d8_during_the_restore() -> None:
            with anyio.fail_after(10):
                while not board.watches._lock.locked():
                    await anyio.lowlevel.checkpoint()
            d8_scope.cancel()

        with anyio.fail_after(30):
            async with anyio.create_task_group() as tg:
                for key in got:
                    tg.start_soon(follow, key)
                tg.start_soon(watch_d8)
                await all_in.wait()
                await d8_in.wait()
                await drive_all(before=0)
                tg.start_soon(cancel_d8_during_the_restore)
                await board.reset(restore=True)
                await drive_all(before=2)
        assert all(
            levels == [(True, 0), (False, 0), (True, 1), (False, 1)] for levels in got.values()
        ), got
        assert board.watches.requests() == []
        async with board.gpio(D3).watch() as changes:
            await uno.drive("D8", 1)  # no longer watched: no event, no sequence number
            await uno.drive("D3", 1)
            with anyio.fail_after(5):
                change = await anext(changes)
        assert (change.pin, change.sequence) == (3, 2 * len(pins))
