"""Analog deadband events on the fake board: the client's rules (loss accounting,
callbacks, shared watches, refusals) without a simulator."""

from __future__ import annotations

import contextlib
import logging

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import A0, A2
from arduinoio_async import protocol as p
from arduinoio_async.board.changes import AnalogMove
from arduinoio_async.errors import BoardError, UsageError, ValueRangeError
from arduinoio_async.testing import FakeBoard

from .fake_boards import connected

pytestmark = pytest.mark.anyio


async def test_moves_past_the_deadband_arrive_in_order_from_the_last_reported_value() -> None:
    async with connected() as (board, fake):
        assert board.capabilities.features & p.Feature.ANALOG_CHANGES
        fake.analog[0] = 500
        got: list[AnalogMove] = []
        async with board.analog(A0).watch(deadband=10) as moves:
            assert moves.baseline == 500
            for value in (510, 490, 520, 511, 509, 600):  # 510: within; 490: 10 from 500
                fake.set_analog(0, value)
            with anyio.fail_after(2):
                async for move in moves:
                    got.append(move)
                    if len(got) == 3:
                        break
        assert [(m.channel, m.value, m.sequence) for m in got] == [
            (0, 520, 0),
            (0, 509, 1),  # 511 is 9 from 520; 509 is 11
            (0, 600, 2),
        ]
        fake.set_analog(0, 0)  # the block ended: no watch, no event
        assert fake.analog_sequence == 3


async def test_loss_on_the_board_is_a_gap_and_a_slow_consumer_drops_the_oldest() -> None:
    arrived: list[AnalogMove] = []
    all_arrived = anyio.Event()

    def count(move: AnalogMove) -> None:
        arrived.append(move)
        if len(arrived) == 4:
            all_arrived.set()

    async with connected() as (board, fake):
        a0 = board.analog(A0)
        async with a0.watch(deadband=1, buffer=2) as moves, a0.on_change(count, deadband=1):
            fake.set_analog(0, 100)
            with anyio.fail_after(2):
                first = await anext(moves)
            fake.analog_sequence += 4  # four events the board could not send
            for value in (200, 300, 400):
                fake.set_analog(0, value)
            with anyio.fail_after(2):
                await all_arrived.wait()
            rest = [await anext(moves), await anext(moves)]
        assert first.sequence == 0
        assert [m.value for m in rest] == [300, 400]
        assert (moves.gaps, moves.dropped, moves.lost) == (4, 1, 5)


async def test_a_failing_callback_is_logged_and_the_link_keeps_working(
    caplog: pytest.LogCaptureFixture,
) -> None:
    called = anyio.Event()

    def broken(move: AnalogMove) -> None:
        called.set()
        raise RuntimeError("user bug")

    async with connected() as (board, fake), board.analog(A2).on_change(broken, deadband=5):
        fake.set_analog(2, 900)
        with anyio.fail_after(2):
            await called.wait()
        assert board.capabilities == await board.request(p.ReadCapabilities())
    assert any("user bug" in str(r.exc_info) for r in caplog.records if r.exc_info)
    assert any(r.levelno == logging.ERROR for r in caplog.records)


async def test_watches_of_one_channel_share_the_board_watch_and_one_deadband() -> None:
    async with connected() as (board, fake):
        a0 = board.analog(A0)
        async with a0.watch(deadband=10) as outer:
            async with a0.watch(deadband=10):
                pass  # its end must not end the outer block's watch
            with pytest.raises(UsageError, match="deadband 10"):
                async with a0.watch(deadband=20):
                    pass
            fake.set_analog(0, 50)
            with anyio.fail_after(2):
                assert (await anext(outer)).value == 50
        # the last block ended the board's watch
        fake.set_analog(0, 900)
        assert fake.analog_sequence == 1


async def test_changes_loop_and_many_tasks_watching_different_channels() -> None:
    async with connected() as (board, fake):
        seen: dict[int, list[int]] = {0: [], 2: []}

        async def consume(channel: int) -> None:
            pin = A0 if channel == 0 else A2
            async with contextlib.aclosing(board.analog(pin).changes(deadband=3)) as moves:
                async for move in moves:
                    seen[channel].append(move.value)
                    if len(seen[channel]) == 5:
                        return

        async def drive(channel: int) -> None:
            for step in range(1, 6):
                # one move at a time, each once the previous one was consumed
                while not (_watched(fake, channel) and len(seen[channel]) == step - 1):
                    await anyio.lowlevel.checkpoint()
                fake.set_analog(channel, 4 * step)

        with anyio.fail_after(5):
            async with anyio.create_task_group() as tg:
                for channel in (0, 2):
                    tg.start_soon(consume, channel)
                    tg.start_soon(drive, channel)
        assert seen == {0: [4, 8, 12, 16, 20], 2: [4, 8, 12, 16, 20]}
        assert fake.analog_sequence == 10


def _watched(fake: FakeBoard, channel: int) -> bool:
    reply = fake._analog_watches.get(channel)  # the model's own state: is it subscribed?
    return reply is not None


async def test_refusals() -> None:
    async with connected() as (board, _fake):
        for band in (0, 1024, -1):
            with pytest.raises(ValueRangeError):
                async with board.analog(A0).watch(deadband=band):
                    pass
        with pytest.raises(BoardError) as refused:
            await board.request(p.AnalogWatch(6, 10))
        assert refused.value.code is p.ErrorCode.PIN_NOT_CAPABLE
        async with board.stream(analog=[A2], period_ms=10):
            with pytest.raises(BoardError, match="stream with analog channels"):
                async with board.analog(A0).watch(deadband=5):
                    pass
        async with board.analog(A0).watch(deadband=5):
            with pytest.raises(BoardError) as refused:
                async with board.stream(analog=[A2], period_ms=10):
                    pass
            assert refused.value.code is p.ErrorCode.PIN_BUSY
