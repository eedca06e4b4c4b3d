"""The encoder handle against the FakeBoard: no simulator, milliseconds.

The FakeBoard's encoder model decodes the levels the test drives (as the firmware does);
the oracle is the position the test drove, in quarter steps.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest

from arduinoio_async import (
    A0,
    A1,
    A2,
    A3,
    A4,
    A5,
    D2,
    D3,
    D4,
    D5,
    D6,
    D7,
    D8,
    D9,
    D10,
    D11,
    D12,
    D13,
    I2CBlock,
)
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.encoders import EncoderState
from arduinoio_async.errors import (
    PinCapabilityError,
    PinRoleError,
    StaleHandleError,
    UsageError,
    ValueRangeError,
)
from arduinoio_async.testing import FakeBoard

#: AB at positions 0-3 going forward (A leads B).
LEVELS = ((False, False), (True, False), (True, True), (False, True))


@asynccontextmanager
async def connected() -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        yield board, fake


def turn(fake: FakeBoard, a: int, b: int, start: int, steps: int) -> int:
    """Quarter steps from ``start``, one pin change each; returns the new position."""
    pos = start
    for _ in range(abs(steps)):
        pos += 1 if steps > 0 else -1
        level_a, level_b = LEVELS[pos % 4]
        if fake.levels[a] != level_a:
            fake.drive(a, level_a)
        else:
            fake.drive(b, level_b)
    return pos


async def test_counts_direction_and_modes() -> None:
    async with connected() as (board, fake):
        for pin in (D2, D3, D4, D5):
            fake.drive(int(pin), False)
        x4 = await board.encoder(a=D2, b=D3)
        x1 = await board.encoder(a=D4, b=D5, mode="x1")
        pos = turn(fake, 2, 3, 0, 37)
        pos = turn(fake, 2, 3, pos, -50)
        assert await x4.count() == pos == -13
        pos1 = turn(fake, 4, 5, 0, 23)
        assert await x1.count() == (pos1 + 3) // 4
        # a skipped state, going the way the encoder last went (back): A changes unseen,
        # B's change shows both
        pos -= 2
        level_a, level_b = LEVELS[pos % 4]
        fake.levels[2] = level_a
        fake.drive(3, level_b)
        state = await x4.read()
        assert (state.count, state.invalid) == (pos, 1)
        before = await x4.preset(1000)
        assert before.count == pos
        assert (await x4.read()).count == 1000


async def test_roles_slots_and_bad_input() -> None:
    async with connected() as (board, _fake):
        await board.counter(D2)
        with pytest.raises(PinRoleError, match="D2 is in use as event counter"):
            await board.encoder(a=D2, b=D4)
        with pytest.raises(PinCapabilityError):
            await board.encoder(a=A0, b=D4)  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError, match="encoder mode"):
            await board.encoder(a=D4, b=D5, mode="x3")  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError, match="pin B"):
            await board.encoder(a=D4, b=D4)
        encoders = [
            await board.encoder(a=a, b=b) for a, b in ((D4, D5), (D6, D7), (D8, D9), (D10, D11))
        ]
        assert [e.slot for e in encoders] == [0, 1, 2, 3]
        with pytest.raises(UsageError, match="all 4 encoder slots"):
            await board.encoder(a=D12, b=D13)
        with pytest.raises(PinRoleError, match="quadrature encoder"):
            await board.digital_output(D5)
        await board.release(D7)  # pin B ends the encoder: both pins free
        assert encoders[1].released and D6 not in board.roles and D7 not in board.roles
        with pytest.raises(StaleHandleError):
            await encoders[1].read()
        again = await board.encoder(a=D12, b=D13)
        assert again.slot == 1


async def test_stream_and_restore_replay_one_setup() -> None:
    async with connected() as (board, fake):
        fake.drive(8, False)
        fake.drive(9, False)
        enc = await board.encoder(a=D8, b=D9, slot=2)
        turn(fake, 8, 9, 0, -7)
        async with board.stream(encoders=True, period_ms=10) as samples:
            async for sample in samples:
                assert sample.encoders == (0, 0, -7, 0)
                break
        setups = board.roles.setups()
        assert setups.count(p.EncoderConfig(2, 8, 9, p.EncoderMode.X4)) == 1
        # 6 channels, levels, edges, counters and encoders (42 bytes) fit the 48 a sample
        # holds; 16 bytes of I2C blocks and their headers more do not
        with pytest.raises(ValueRangeError, match="stream content"):
            async with board.stream(
                analog=[A0, A1, A2, A3, A4, A5],
                levels=True,
                edges=True,
                counters=True,
                encoders=True,
                i2c=[I2CBlock(0x68, 0x3B, 16)],
            ):
                pass
        assert await enc.count() == -7


def test_velocity_from_edge_times() -> None:
    earlier = EncoderState(count=100, invalid=0, edge_us=1_000_000)
    later = EncoderState(count=-100, invalid=0, edge_us=1_100_000)
    assert later.velocity_since(earlier) == pytest.approx(-2_000.0)
    assert earlier.velocity_since(earlier) == 0.0
    wrapped = EncoderState(count=2**31 - 1, invalid=0, edge_us=50)
    after = EncoderState(count=-(2**31) + 9, invalid=0, edge_us=10)  # both wrapped
    assert after.velocity_since(wrapped) * ((10 - 50) % 2**32) / 1e6 == pytest.approx(10)
