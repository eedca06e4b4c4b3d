"""Duty PWM, motors and servo limits in the library, against FakeBoard.

The timer rules are checked before anything is sent: each refusal here names the other
user of the timer, and the fake board (which follows the firmware's checks) is never
asked.  Waveforms are measured on the virtual Uno (tests/e2e/test_motors.py).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest

from arduinoio_async import A0, D2, D3, D5, D6, D7, D8, D9, D10, D11
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import (
    PinCapabilityError,
    PinRoleError,
    TimerBusyError,
    ValueRangeError,
)
from arduinoio_async.testing import FakeBoard


@asynccontextmanager
async def connected() -> AsyncIterator[tuple[Board, FakeBoard]]:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        yield board, fake


async def test_a_servo_on_timer1_refuses_duty_pwm_on_the_other_pin_before_sending() -> None:
    async with connected() as (board, fake):
        await board.servo(D10, pulse_us=1500)
        with pytest.raises(TimerBusyError) as info:
            await board.pwm(D9, 0.5, frequency_hz=31250)
        assert str(info.value) == (
            "D9 and D10 share Timer1: D10 is servo PWM, so D9 cannot take duty-cycle PWM "
            "at 31250 Hz"
        )
        assert fake.role(9) == "free"  # nothing was sent
        assert isinstance(info.value, PinRoleError)


async def test_duty_pwm_on_timer1_refuses_a_servo_and_another_frequency() -> None:
    async with connected() as (board, fake):
        d9 = await board.pwm(D9, 0.5, frequency_hz=31250)
        assert fake.duties[9] == (31250, round(0.5 * p.DUTY_FULL))
        with pytest.raises(TimerBusyError, match="which D9 holds for duty-cycle PWM at 31250"):
            await board.servo(D10)
        with pytest.raises(TimerBusyError, match="D9 is duty-cycle PWM at 31250 Hz"):
            await board.pwm(D10, frequency_hz=490)
        d10 = await board.pwm(D10)  # no frequency: the timer's
        assert d10.frequency_hz == 31250 and d10.steps == 512
        await d9.release()
        await d10.release()
        await board.servo(D10)  # Timer1 is free again


async def test_timer0_duty_pwm_and_software_pwm_exclude_each_other() -> None:
    async with connected() as (board, fake):
        soft = await board.soft_pwm(D2, pulse_us=1500)
        with pytest.raises(TimerBusyError, match="Timer0, whose alarms run software PWM on D2"):
            await board.pwm(D5)
        await soft.release()
        await board.pwm(D6, 0.2, frequency_hz=62500)
        with pytest.raises(TimerBusyError, match="software PWM needs Timer0"):
            await board.soft_pwm(D2)
        assert fake.role(2) == "free"


async def test_pins_and_frequencies_outside_the_timers_are_refused() -> None:
    async with connected() as (board, _fake):
        with pytest.raises(PinCapabilityError, match="OCR2A sets the board tick"):
            await board.pwm(D11)  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError, match="one of 10000"):
            await board.pwm(D3, frequency_hz=490)
        with pytest.raises(ValueRangeError, match=r"0\.0-1\.0"):
            await board.pwm(D3, 1.5)


async def test_motor_speed_sign_brake_coast_and_its_failsafe_state() -> None:
    async with connected() as (board, fake):
        motor = await board.motor(D9, D7, D8, frequency_hz=20000)
        await motor.set_speed(-0.5)
        assert (fake.levels[7], fake.levels[8]) == (False, True)
        assert fake.duties[9] == (20000, round(0.5 * p.DUTY_FULL))
        await motor.brake()
        assert (fake.levels[7], fake.levels[8]) == (True, True)
        assert fake.duties[9][1] == p.DUTY_FULL and motor.state == "brake"
        await motor.coast()
        assert fake.duties[9][1] == 0 and motor.state == "coast"
        with pytest.raises(ValueRangeError):
            await motor.set_speed(1.2)
        await board.arm_failsafe(100, {motor: 0})
        assert fake.failsafe.safe[9] == (p.SafeKind.DUTY, 0)


async def test_servo_limits_default_narrow_and_widen_to_the_full_range() -> None:
    async with connected() as (board, fake):
        servo = await board.servo(D9)
        with pytest.raises(ValueRangeError, match="1000-2000"):
            await servo.set_pulse(2400)
        servo.set_limits(500, 2500)
        await servo.set_pulse(2400)
        assert fake.pulses[9] == 2400
        await servo.set_angle(0)
        assert fake.pulses[9] == 500
        with pytest.raises(ValueRangeError):
            servo.set_limits(400, 2500)


def test_mypy_refuses_pwm_on_a_pin_without_a_hardware_timer(tmp_path: Path) -> None:
    snippet = tmp_path / "misuse.py"
    snippet.write_text(
        textwrap.dedent(
            """
            from arduinoio_async import D4, D9, D11
            from arduinoio_async.board import Board

            async def main(board: Board) -> None:
                await board.pwm(D9, 0.5)
                await board.pwm(D4, 0.5)
                await board.pwm(D11, 0.5)
                await board.motor_2pwm(D9, D4)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(snippet)],
        capture_output=True,
        text=True,
        check=False,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert [e.split(":")[1] for e in errors] == ["7", "8", "9"], result.stdout


async def test_a_stream_and_timer0_duty_pwm_refuse_each_other_before_sending() -> None:
    async with connected() as (board, fake):
        async with board.stream(analog=[A0], period_ms=10):
            with pytest.raises(TimerBusyError, match="Timer0, whose alarms time the stream"):
                await board.pwm(D6)
        assert fake.role(6) == "free"
        await board.pwm(D6, 0.5)
        with pytest.raises(TimerBusyError, match="D6 holds for duty-cycle PWM"):
            async with board.stream(analog=[A0], period_ms=10):
                pass
        assert not fake.stream.running


async def test_leaving_the_brake_never_drives_at_full_duty_on_the_way() -> None:
    """From brake (enable full on, IN1 = IN2 high) to a speed: the enable must drop to 0
    before a direction input changes, or the motor gets full power for a round trip."""
    sent: list[p.Frame] = []
    async with FakeBoard() as fake:
        trace = lambda record: sent.append(record.item) if record.direction == "tx" else None  # noqa: E731
        async with Board.connect(fake.host_stream, trace=trace) as board:
            motor = await board.motor(D9, D7, D8, frequency_hz=20000)
            await motor.brake()
            sent.clear()
            await motor.set_speed(0.5)
    writes = [f for f in sent if isinstance(f, p.GpioWrite | p.PwmDutySet)]
    first_direction = next(i for i, f in enumerate(writes) if isinstance(f, p.GpioWrite))
    assert writes[0] == p.PwmDutySet(9, 0), writes  # the drive is off first
    assert first_direction > 0
