"""The board's public pin-role table (``board.roles``): claim, conflict, release, staleness.

Against the in-memory fake board, whose own record of roles is the oracle for what the
board was told; the table must agree with it and refuse what the board would refuse.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D3, D4, D5, D9, PinRoleError, StaleHandleError
from arduinoio_async import protocol as p
from arduinoio_async.board import Claim, PinRoles
from arduinoio_async.board.handles import DigitalOutput, input_setup, output_setup
from arduinoio_async.errors import BoardError

from .fake_boards import connected


async def test_the_table_shows_each_claimed_pin_with_its_handle_and_setup() -> None:
    async with connected() as (board, fake):
        assert isinstance(board.roles, PinRoles) and len(board.roles) == 0
        out = await board.digital_output(D4, initial=True)
        servo = await board.servo(D9, pulse_us=1500)
        assert board.roles[D4] == Claim(out, output_setup(D4, True))
        assert board.roles[D4].role == "digital output" and fake.role(4) == "output"
        assert board.roles.holder(D9) is servo and board.roles.holder(D5) is None
        assert list(board.roles) == [D4, D9] and D5 not in board.roles
        await out.write(False)  # the replay record follows the level the board drives now
        await servo.set_pulse(1200)
        assert board.roles[D4].setup == output_setup(D4, False)
        assert board.roles.setups() == [output_setup(D4, False), p.PwmConfig(D9, 1200)]
        bus = await board.i2c(p.I2CSpeed.KHZ_400)
        assert board.roles.i2c is bus
        assert board.roles.setups()[-1] == p.I2CConfig(p.I2CSpeed.KHZ_400)


async def test_a_conflicting_claim_names_the_pin_and_its_holder_and_changes_nothing() -> None:
    async with connected() as (board, fake):
        out = await board.digital_output(D4)
        seen = fake.requests_seen
        with pytest.raises(PinRoleError, match="D4 is in use as digital output") as info:
            board.roles.claim(board.gpio(D4), input_setup(D4, True))
        assert (info.value.pin, info.value.current, info.value.requested) == (
            "D4",
            "digital output",
            "GPIO",
        )
        with pytest.raises(PinRoleError, match="D4 is in use as digital output"):
            await board.digital_input(D4)
        assert board.roles.holder(D4) is out
        assert fake.requests_seen == seen and fake.role(4) == "output"


async def test_release_frees_the_pin_and_marks_the_handle_released() -> None:
    async with connected() as (board, fake):
        out = await board.digital_output(D4)
        await board.release(D4)
        assert D4 not in board.roles and out.released and fake.role(4) == "free"
        assert board.roles.release(D5) is None  # nothing held: nothing to mark
        newer = await board.digital_input(D4)
        assert board.roles.holder(D4) is newer and not newer.released


async def test_stale_and_foreign_handles_cannot_claim_or_amend() -> None:
    async with connected() as (board, _fake), connected(0x0043) as (other, _other_fake):
        old = await board.digital_output(D4)
        await old.release()
        with pytest.raises(StaleHandleError, match="was released"):
            board.roles.claim(old, output_setup(D4, True))
        board.roles.amend(old, output_setup(D4, True))  # a late amend of an ended role
        assert D4 not in board.roles
        foreign = DigitalOutput(other, D3)
        with pytest.raises(StaleHandleError, match="another board"):
            board.roles.claim(foreign, output_setup(D3, True))
        with pytest.raises(StaleHandleError, match="another board"):
            await board.set_up(foreign, output_setup(D3, True))
        assert D3 not in board.roles


async def test_two_tasks_asking_for_one_pin_at_once_get_one_handle_and_one_error() -> None:
    async with connected() as (board, fake):
        handles: list[DigitalOutput] = []
        refusals: list[PinRoleError] = []

        async def take(level: bool) -> None:
            try:
                handles.append(await board.digital_output(D4, initial=level))
            except PinRoleError as exc:
                refusals.append(exc)

        seen = fake.requests_seen
        async with anyio.create_task_group() as tg:
            for level in (True, False, True, False):
                tg.start_soon(take, level)
        assert len(handles) == 1 and len(refusals) == 3
        assert fake.requests_seen == seen + 1  # the refused ones never reached the board
        winner = handles[0]
        assert board.roles.holder(D4) is winner
        assert fake.levels[4] is (board.roles[D4].setup == output_setup(D4, True))


async def test_a_setup_the_board_refuses_leaves_no_claim() -> None:
    async with connected() as (board, fake):
        await board.request(p.PwmConfig(D9, 1500))  # raw: the board's role, not the table's
        with pytest.raises(BoardError):
            await board.digital_output(D9)
        assert D9 not in board.roles and fake.role(9) != "output"
        await board.request(p.PinRelease(int(D9)))
        out = await board.digital_output(D9)
        assert board.roles.holder(D9) is out and fake.role(9) == "output"


async def test_a_gpio_direction_change_the_board_refuses_keeps_the_previous_setup() -> None:
    async with connected() as (board, _fake):
        gpio = board.gpio(D5)
        await gpio.write(True)
        before = board.roles[D5]
        with anyio.CancelScope() as scope:
            scope.cancel()  # the set-up request is cancelled before it completes
            await gpio.configure_input(pull_up=True)
        assert board.roles[D5] == before


async def test_the_table_is_read_only_for_users() -> None:
    async with connected() as (board, _fake):
        await board.digital_output(D4)
        with pytest.raises(TypeError):
            board.roles[D4] = board.roles[D4]  # type: ignore[index]
        with pytest.raises(AttributeError):
            board.roles = PinRoles(board)  # type: ignore[misc]
