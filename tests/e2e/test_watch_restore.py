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
import pytest

from arduinoio_async import A0, D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.changes import AnalogChanges, ChangeStream, CountReports
from arduinoio_async.errors import WatchLostError
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.sim.virtual_uno import VirtualUno

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
    await uno.drive("D3", 1)
    await uno.drive("D3", 0)
    await uno.pulses("D2", count=10, high_us=200, low_us=300)
    await uno.set_analog(0, mv(analog))
    with anyio.fail_after(10):
        rise, fall = await anext(watched.changes), await anext(watched.changes)
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
        reset_seen = anyio.Event()

        def on_event(event: ManagerEvent) -> None:
            if event.kind == "reset":
                reset_seen.set()

        boards.subscribe(on_event)

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
        assert "PIN_NOT_CONFIGURED" in lost.value.reason
        assert (await board.gpio(D3).read()).level is True  # the output role was restored
