"""Transactions through the client on the fake board: order, per-item errors, typing."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D2, D3, D4, D5, D6, D7, D13
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError, FailsafeTrippedError, ValueRangeError

from .fake_boards import connected

pytestmark = pytest.mark.anyio


async def test_items_run_in_order_and_each_gets_its_reply() -> None:
    async with connected() as (board, fake):
        assert board.capabilities.features & p.Feature.TRANSACTIONS
        await board.digital_output(D13)
        before = fake.requests_seen
        async with board.transaction() as tx:
            first = tx.add(p.GpioRead(D13))
            tx.add(p.GpioWrite(D13, True))
            after = tx.add(p.GpioRead(D13))
            assert not after.done
            with pytest.raises(RuntimeError, match="not run"):
                after.result()
        assert fake.requests_seen == before + 1  # one frame
        assert first.result().level is False
        assert after.result().level is True  # the write ran before the second read


async def test_a_refused_item_raises_its_own_error_and_the_others_still_run() -> None:
    async with connected() as (board, fake):
        await board.digital_output(D13)
        async with board.transaction() as tx:
            refused = tx.add(p.GpioWrite(D7, True))  # D7 is no output
            write = tx.add(p.GpioWrite(D13, True))
        with pytest.raises(BoardError) as caught:
            refused.result()
        assert caught.value.code is p.ErrorCode.PIN_NOT_CONFIGURED
        assert caught.value.request == p.GpioWrite(D7, True)
        assert refused.error is caught.value
        assert write.result() == p.GpioWriteReply(D13, True)
        assert fake.levels[13] is True


async def test_six_servo_widths_in_one_frame() -> None:
    async with connected() as (board, fake):
        pins = (D2, D3, D4, D5, D6, D7)
        for pin in pins:
            await board.soft_pwm(pin)  # type: ignore[arg-type]
        async with board.transaction() as tx:
            items = [tx.add(p.PwmSet(pin, 1000 + 100 * n)) for n, pin in enumerate(pins)]
        assert [item.result().pulse_us for item in items] == [1000, 1100, 1200, 1300, 1400, 1500]
        assert [fake.pulses[int(pin)] for pin in pins] == [1000, 1100, 1200, 1300, 1400, 1500]


async def test_what_one_frame_cannot_hold_is_refused_before_sending() -> None:
    async with connected() as (board, fake):
        tx = board.transaction()
        tx.add(p.AnalogReadAll())
        tx.add(p.AnalogReadAll())
        before = fake.requests_seen
        with pytest.raises(ValueRangeError):
            tx.add(p.AnalogReadAll())  # 3 x 14 result bytes > 32
        with pytest.raises(ValueRangeError):
            tx.add(p.Reset())
        assert len(tx) == 2
        await tx.run()
        with pytest.raises(RuntimeError, match="already run"):
            await tx.run()
        assert fake.requests_seen == before + 1


async def test_a_tripped_failsafe_refuses_output_items_only() -> None:
    async with connected() as (board, fake):
        led = await board.digital_output(D13)
        await board.arm_failsafe(1000, {led: False})
        await fake.expire_failsafe()
        async with board.transaction() as tx:
            write = tx.add(p.GpioWrite(D13, True))
            read = tx.add(p.GpioRead(D13))
        with pytest.raises(FailsafeTrippedError):
            write.result()
        assert read.result().level is False


async def test_many_tasks_mix_transactions_and_requests() -> None:
    async with connected() as (board, _fake):
        outputs = [D2, D3, D4, D5]
        for pin in outputs:
            await board.digital_output(pin)
        errors: list[BaseException] = []

        async def worker(pin: int, rounds: int) -> None:
            for n in range(rounds):
                level = bool(n % 2)
                async with board.transaction() as tx:
                    tx.add(p.GpioWrite(pin, level))
                    read = tx.add(p.GpioRead(pin))
                if read.result().level is not level:
                    errors.append(AssertionError((pin, n)))
                assert await board.read_id() == 0x0042

        async with anyio.create_task_group() as tg:
            for pin in outputs:
                tg.start_soon(worker, pin, 25)
        assert not errors
