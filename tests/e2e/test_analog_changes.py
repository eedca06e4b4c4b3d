"""Analog deadband events on the virtual Uno (protocol extension, docs/protocol.md 7.4).

The fixture sets the voltage on A0; the oracle for each reported value is a blocking
ANALOG READ of the same voltage, and "no event" is proven by the next move's event
arriving with the next sequence number, never by waiting.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import A0, A1, A4
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.changes import AnalogChanges, AnalogMove
from arduinoio_async.errors import BoardError, PinRoleError, ValueRangeError
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: One ADC count is about 5000 / 1024 mV; a value set as counts may convert one count off
#: (the fixture's millivolts are whole), so the oracle is a READ of the same voltage.
COUNT_MV = 5000 / 1024


def mv(counts: int) -> float:
    return (counts + 0.5) * COUNT_MV


async def next_move(moves: AnalogChanges) -> AnalogMove:
    with anyio.fail_after(5):
        return await anext(moves)


async def test_a_move_past_the_deadband_reports_once_and_a_move_within_it_never(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    await uno.set_analog(0, mv(400))
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        a0 = board.analog(A0)
        assert board.capabilities.features & p.Feature.ANALOG_CHANGES
        async with a0.watch(deadband=20) as moves:
            assert moves.baseline == await a0.read()
            assert abs(moves.baseline - 400) <= 1
            await uno.set_analog(0, mv(410))  # within the deadband: no event
            assert abs(await a0.read() - 410) <= 1  # the board sees it, sampled meanwhile
            await uno.set_analog(0, mv(600))
            first = await next_move(moves)
            assert (first.channel, first.sequence) == (0, 0)
            assert first.value == await a0.read()
            assert abs(first.value - 600) <= 1
            await uno.set_analog(0, mv(first.value - 15))  # within, from the reference
            assert abs(await a0.read() - (first.value - 15)) <= 1
            await uno.set_analog(0, mv(first.value - 40))  # past it
            second = await next_move(moves)
            assert second.sequence == 1
            assert second.value == await a0.read()
            assert abs(second.value - (first.value - 40)) <= 1
            assert (second.board_time_us - first.board_time_us) & 0xFFFFFFFF > 0
            assert moves.pending() == 0 and moves.lost == 0


async def test_the_callback_form_and_two_channels_with_a_shared_sequence(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    seen: list[AnalogMove] = []
    first_arrived = anyio.Event()
    arrived = anyio.Event()

    def on_move(move: AnalogMove) -> None:
        seen.append(move)
        first_arrived.set()
        if len(seen) == 2:
            arrived.set()

    async with Board.open(uno.port, baudrate=uno.baud) as board:
        async with (
            board.analog(A0).on_change(on_move, deadband=50),
            board.analog(A1).watch(deadband=50) as a1_moves,
        ):
            await uno.set_analog(0, mv(100))
            # A0's move is reported before A1 is moved: the board scans the channels in
            # turn, so two moves made together may be reported in either order.
            with anyio.fail_after(5):
                await first_arrived.wait()
            await uno.set_analog(1, mv(900))
            a1 = await next_move(a1_moves)
            await uno.set_analog(0, mv(300))
            with anyio.fail_after(5):
                await arrived.wait()
        assert all(abs(m.value - v) <= 1 for m, v in zip(seen, (100, 300), strict=True))
        assert abs(a1.value - 900) <= 1
        # one count for both channels: A1's event sits between A0's two
        assert seen[0].sequence < a1.sequence < seen[1].sequence
        assert a1_moves.gaps == 0  # every event of either channel passed its listener
        # the watch ended with its block: a new move reports to nobody and the next
        # watch starts from a fresh baseline
        await uno.set_analog(0, mv(700))
        async with board.analog(A0).watch(deadband=50) as moves:
            assert moves.baseline is not None and abs(moves.baseline - 700) <= 1


async def test_refusals(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        a0 = board.analog(A0)
        for band in (0, 1024):
            with pytest.raises(ValueRangeError):
                async with a0.watch(deadband=band):
                    pass
        with pytest.raises(BoardError) as refused:
            await board.request(p.AnalogWatch(6, 10))
        assert refused.value.code is p.ErrorCode.PIN_NOT_CAPABLE
        with pytest.raises(BoardError) as refused:
            await board.request(p.AnalogWatch(0, 1024))
        assert refused.value.code is p.ErrorCode.VALUE_OUT_OF_RANGE
        # the ADC has one user: an analog stream and a watch exclude each other
        async with a0.watch(deadband=10):
            with pytest.raises(BoardError) as refused:
                async with board.stream(analog=[A1], period_ms=10):
                    pass
            assert refused.value.code is p.ErrorCode.PIN_BUSY
        async with board.stream(analog=[A1], period_ms=10):
            with pytest.raises(BoardError, match="running stream with analog channels"):
                async with a0.watch(deadband=10):
                    pass
        async with board.stream(levels=True, period_ms=10), a0.watch(deadband=10) as moves:
            await uno.set_analog(0, mv(800))
            assert abs((await next_move(moves)).value - 800) <= 1
        await board.i2c()
        with pytest.raises(PinRoleError):
            board.analog(A4)
        with pytest.raises(BoardError) as refused:
            await board.request(p.AnalogWatch(4, 10))
        assert refused.value.code is p.ErrorCode.PIN_BUSY
