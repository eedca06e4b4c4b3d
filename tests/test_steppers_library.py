"""Steppers in the library, against FakeBoard (issue 26): values checked before sending,
pin roles naming the stepper, slots, homing, and the fake board's model of the motion
(exact targets, limit switches, the failsafe).  Step pulses are measured on the virtual
Uno (tests/e2e/test_steppers.py)."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11, D12, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.steppers import HomingError
from arduinoio_async.errors import BoardError, PinRoleError, UsageError, ValueRangeError
from arduinoio_async.testing import FakeBoard


@asynccontextmanager
async def connected() -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        yield board, fake


async def test_values_outside_the_boards_range_are_refused_before_sending() -> None:
    async with connected() as (board, fake):
        with pytest.raises(ValueRangeError, match="1-10000"):
            await board.stepper(step=D2, dir=D3, max_speed=10_001)
        with pytest.raises(ValueRangeError, match="acceleration"):
            await board.stepper(step=D2, dir=D3, acceleration=0)
        with pytest.raises(ValueError, match="two pins"):
            await board.stepper(step=D2, dir=D2)
        stepper = await board.stepper(step=D2, dir=D3)
        seen = fake.requests_seen
        with pytest.raises(ValueRangeError, match="32-bit"):
            await stepper.move_to(2**31)
        with pytest.raises(ValueRangeError, match="run speed"):
            await stepper.run(-10_001)
        assert fake.requests_seen == seen


async def test_roles_name_the_stepper_and_four_slots_is_the_limit() -> None:
    async with connected() as (board, _fake):
        steppers = [
            await board.stepper(step=s, dir=d) for s, d in ((D2, D3), (D4, D5), (D6, D7), (D8, D9))
        ]
        assert [s.index for s in steppers] == [0, 1, 2, 3]
        with pytest.raises(PinRoleError, match="D5 is in use as stepper 1's direction pin"):
            await board.digital_output(D5)
        with pytest.raises(UsageError, match="4 stepper slots are in use"):
            await board.stepper(step=D10, dir=D11)
        await steppers[1].release()
        again = await board.stepper(step=D10, dir=D11)
        assert again.index == 1
        await board.digital_output(D5)  # freed with its stepper


async def test_a_move_ends_at_its_target_and_the_board_says_so() -> None:
    async with connected() as (board, fake):
        stepper = await board.stepper(step=D2, dir=D3, max_speed=5000, acceleration=100_000)
        assert await stepper.move_by(300) == 300
        state = await stepper.wait(timeout=5)
        assert state.position == 300 and fake.steppers.steps_out[2] == 300
        assert stepper.last_done is not None
        assert stepper.last_done.reason is p.StepperDoneReason.TARGET
        with pytest.raises(BoardError, match="the stepper is moving"):
            await stepper.run(2000)
            await stepper.set_position(0)


async def test_homing_stops_at_the_switch_or_says_why_not() -> None:
    async with connected() as (board, fake):
        stepper = await board.stepper(step=D12, dir=D13, max_speed=5000, acceleration=100_000)
        with pytest.raises(UsageError, match="no negative limit switch"):
            await stepper.home(1000)
        await stepper.limit(D4)
        fake.drive(D4, False)  # the carriage already sits on the switch
        assert await stepper.home(1000) == 0
        fake.drive(D4, True)
        await stepper.move_to(200)
        await stepper.wait(timeout=5)
        failure: list[BaseException] = []

        async def homing() -> None:
            try:
                await stepper.home(1000, timeout=5)
            except HomingError as exc:
                failure.append(exc)

        async with anyio.create_task_group() as tg:
            tg.start_soon(homing)
            with anyio.fail_after(5):
                while fake.steppers.steps_out.get(12, 0) < 210:  # noqa: ASYNC110 - model state
                    await anyio.sleep(0.001)
            await stepper.stop(immediate=True)
        assert failure and "STOPPED" in str(failure[0])


async def test_a_reset_with_restore_sets_the_stepper_up_again() -> None:
    async with connected() as (board, fake):
        stepper = await board.stepper(step=D6, dir=D7, max_speed=3000, acceleration=30_000)
        await stepper.limit(D8)
        await stepper.move_to(120)
        await stepper.wait(timeout=5)
        await board.reset(restore=True)
        slot = fake.steppers.slots[0]
        assert slot is not None and (slot.step, slot.dir_pin) == (6, 7)
        assert (slot.max_speed, slot.acceleration) == (3000, 30_000) and 0 in slot.limits
        assert (await stepper.read()).position == 0  # the board's RAM was lost
        await stepper.move_to(50)
        assert (await stepper.wait(timeout=5)).position == 50
