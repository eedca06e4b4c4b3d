"""The FakeBoard playing the whole Mega (MEGA2560_FULL): its timers, servo pins, A0-A15.

Oracles: the Mega's data sheet as protocol/boards.py's MEGA2560_HARDWARE writes it (OC1A/B
on D11/D12, OC3A-C on D5/D2/D3, OC4A-C on D6/D7/D8, OC5A-C on D46/D45/D44) and the fake's
own recorded state (``duties``, ``pulses``, ``analog``), read back over the wire.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import BoardError
from arduinoio_async.protocol.boards import MEGA2560_FULL
from arduinoio_async.testing import FakeBoard

#: The Mega's 16-bit timers and the output compare pins of each.
MEGA_TIMERS = {1: (11, 12), 3: (5, 2, 3), 4: (6, 7, 8), 5: (46, 45, 44)}


@asynccontextmanager
async def on_mega() -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with (
        FakeBoard(board_id=0x0042, model=MEGA2560_FULL) as fake,
        Board.connect(fake.host_stream, timeout=0.5, ready_timeout=2) as board,
    ):
        yield board, fake


@pytest.mark.parametrize("timer", sorted(MEGA_TIMERS))
async def test_duty_pwm_on_every_mega_timer_shares_its_frequency(timer: int) -> None:
    """Every pin of a timer takes duty PWM; a second frequency on the same timer is refused
    (the pins share TOP), another timer's pin is free to choose its own."""
    first, second = MEGA_TIMERS[timer][0], MEGA_TIMERS[timer][1]
    other = next(pins[0] for t, pins in MEGA_TIMERS.items() if t != timer)
    async with on_mega() as (board, fake):
        await board.request(p.PwmDutyConfig(first, 20000, 100))
        await board.request(p.PwmDutyConfig(second, 20000, 200))
        assert fake.duties == {first: (20000, 100), second: (20000, 200)}
        with pytest.raises(BoardError) as refused:
            await board.request(p.PwmDutyConfig(second, 976, 300))
        assert refused.value.code == p.ErrorCode.PIN_BUSY
        await board.request(p.PwmDutyConfig(other, 976, 5))
        assert fake.duties[other] == (976, 5)


async def test_a_servo_holds_its_mega_timer_against_duty_pwm() -> None:
    """Servo PWM on D2 (OC3B) needs Timer3's 20 ms period: duty PWM on D5 (OC3A) is refused,
    on D6 (Timer4) allowed; the servo takes any microsecond (no soft-PWM steps on the Mega)."""
    async with on_mega() as (board, fake):
        await board.request(p.PwmConfig(2, 1501))
        assert fake.pulses[2] == 1501
        with pytest.raises(BoardError) as refused:
            await board.request(p.PwmDutyConfig(5, 20000, 100))
        assert refused.value.code == p.ErrorCode.PIN_BUSY
        await board.request(p.PwmDutyConfig(6, 20000, 100))
        with pytest.raises(BoardError) as busy:
            await board.request(p.PwmConfig(7, 1500))  # Timer4 runs duty PWM now
        assert busy.value.code == p.ErrorCode.PIN_BUSY


@pytest.mark.parametrize("channel", range(16))
async def test_every_mega_analog_input_reads_its_level(channel: int) -> None:
    async with on_mega() as (board, fake):
        fake.analog[channel] = 17 + channel * 60
        reply = await board.request(p.AnalogRead(channel))
        assert (reply.channel, reply.value) == (channel, 17 + channel * 60)
