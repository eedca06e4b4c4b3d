"""Duty-cycle PWM, motors and the full servo range on the virtual Uno.

Every oracle is the fixture's: the pin's edges timestamped with the simulated cycle
counter (firmware/sim, pulse capture), never a register or the library's own answer.
"Within one timer tick" is one count of the pin's timer (prescaler / 16 MHz).
"""

from __future__ import annotations

import io
import statistics
import time

import anyio
import pytest
from rich.console import Console

from arduinoio_async import D3, D4, D5, D6, D7, D8, D9, D10
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.motors import DutyPwm
from arduinoio_async.cli import main as cli_main
from arduinoio_async.protocol.pins import DutyPwmPin
from arduinoio_async.protocol.timers import DUTY_FREQUENCIES, TIMER_OF, Timer, timer_setting
from arduinoio_async.sim import PulseStats, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import control_now, fresh_pulses, steady_level

pytestmark = pytest.mark.sim

#: One pin per timer for the frequency sweep.
SWEEP_PINS: dict[Timer, DutyPwmPin] = {Timer.TIMER0: D5, Timer.TIMER1: D9, Timer.TIMER2: D3}


#: The fixture reports times in us with 3 decimals (firmware/sim/control.c).
REPORTED_US = 0.0005
#: simavr runs its timer events between instructions, so a compare-output edge is stamped
#: at the end of the instruction (or interrupt entry) it fell in: up to 4 cycles late
#: (firmware/sim/README.md, "Pulse capture"). Below the resolution of a clk/1 timer, so a
#: single high time is checked within one timer tick plus that, their median within one
#: timer tick.
EDGE_STAMP_US = 4 / 16


def tick_us(handle: DutyPwm) -> float:
    """One count of the handle's timer in microseconds, plus the report's rounding."""
    return timer_setting(handle.timer, handle.frequency_hz).prescaler / 16.0 + REPORTED_US


def expected_high_us(handle: DutyPwm, duty: float) -> float:
    """What the board should output: the duty on the wire rounded to the timer's counts."""
    counts = handle.steps
    raw = round(duty * p.DUTY_FULL)
    prescaler = timer_setting(handle.timer, handle.frequency_hz).prescaler
    return round(raw * counts / p.DUTY_FULL) * prescaler / 16.0


async def measured(uno: VirtualUno, pin: str, count: int = 8) -> PulseStats:
    """A fresh capture of at least ``count`` whole periods on ``pin``."""
    return await fresh_pulses(uno, pin, count + 1, within=10.0)


async def check_duty(uno: VirtualUno, handle: DutyPwm, duty: float) -> tuple[float, float]:
    """Set ``duty`` and check the pin's high time and period within one timer tick; returns
    the measured (high, period) medians in us."""
    await handle.set_duty(duty)
    period = handle.steps * timer_setting(handle.timer, handle.frequency_hz).prescaler / 16.0
    pin = handle.pin.name
    if expected_high_us(handle, duty) in (0.0, period):  # held low or high: no edge at all
        level = await steady_level(uno, pin, 10 * period)
        assert level == (1 if duty else 0), (pin, duty, level)
        return (period if level else 0.0), period
    stats = await measured(uno, pin)
    highs, periods = stats.high_us[-7:], stats.period_us[-7:]
    want = expected_high_us(handle, duty)
    tick = tick_us(handle)
    high, whole = statistics.median(highs), statistics.median(periods)
    assert abs(high - want) <= tick, (pin, duty, want, highs)
    assert abs(whole - period) <= tick, (pin, period, periods)
    assert all(abs(h - want) <= tick + EDGE_STAMP_US for h in highs), (pin, duty, want, highs)
    assert all(abs(t - period) <= tick + EDGE_STAMP_US for t in periods), (pin, periods)
    return high, whole


async def test_duty_0_1_37_50_100_percent_on_every_timer(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        handles = [
            await board.pwm(D9, frequency_hz=3906),  # Timer1, 12 bits
            await board.pwm(D6, frequency_hz=976),  # Timer0, Arduino's analogWrite rate
            await board.pwm(D3),  # Timer2 at the tick's 10 kHz
        ]
        for handle in handles:
            for duty in (0.0, 0.01, 0.37, 0.5, 1.0):
                await check_duty(uno, handle, duty)


async def test_every_offered_frequency_within_one_timer_tick(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        report = []
        for timer, pin in SWEEP_PINS.items():
            for hz in DUTY_FREQUENCIES[timer]:
                handle = await board.pwm(pin, frequency_hz=hz)
                high, period = await check_duty(uno, handle, 0.37)
                report.append(f"{pin.name} {hz} Hz: {1e6 / period:.1f} Hz, {high / period:.4f}")
                await handle.release()
        print("\nduty PWM, 37 %: " + "; ".join(report))


async def test_two_pins_of_one_timer_share_its_frequency(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        d9 = await board.pwm(D9, 0.25, frequency_hz=31250)
        d10 = await board.pwm(D10, 0.75)  # takes Timer1's frequency
        assert d10.frequency_hz == 31250
        await check_duty(uno, d9, 0.25)
        await check_duty(uno, d10, 0.75)


async def pin_level(uno: VirtualUno, pin: str) -> int:
    return (await uno.pin(pin)).level


async def test_motor_direction_brake_and_coast(virtual_uno_factory: VirtualUnoFactory) -> None:
    """L298N/TB6612 wiring: PWM on D9, IN1 on D7, IN2 on D8."""
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        motor = await board.motor(D9, D7, D8, frequency_hz=20000)
        pwm = motor.speed_pins[0]
        await motor.set_speed(0.5)
        assert (await pin_level(uno, "D7"), await pin_level(uno, "D8")) == (1, 0)
        await check_duty(uno, pwm, 0.5)
        await motor.set_speed(-0.25)
        assert (await pin_level(uno, "D7"), await pin_level(uno, "D8")) == (0, 1)
        stats = await measured(uno, "D9")
        want = expected_high_us(pwm, 0.25)
        assert all(abs(h - want) <= tick_us(pwm) + EDGE_STAMP_US for h in stats.high_us)
        await motor.brake()  # IN1 = IN2 = high, enable full on: terminals shorted
        assert (await pin_level(uno, "D7"), await pin_level(uno, "D8")) == (1, 1)
        assert await steady_level(uno, "D9", 500) == 1
        await motor.coast()  # enable off: terminals open
        assert await steady_level(uno, "D9", 500) == 0


async def test_two_pwm_motor_drives_one_input_at_a_time(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """DRV8833 wiring: IN1 on D9, IN2 on D10 (one timer, one frequency)."""
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        motor = await board.motor_2pwm(D9, D10, frequency_hz=20000)
        in1, in2 = motor.speed_pins
        await motor.set_speed(0.6)
        await check_duty(uno, in1, 0.6)
        assert await steady_level(uno, "D10", 500) == 0
        await motor.set_speed(-0.3)
        assert await steady_level(uno, "D9", 500) == 0
        stats = await measured(uno, "D10")
        want = expected_high_us(in2, 0.3)
        assert all(abs(h - want) <= tick_us(in2) + EDGE_STAMP_US for h in stats.high_us)
        await motor.brake()
        assert await steady_level(uno, "D9", 500) == 1
        assert await steady_level(uno, "D10", 500) == 1


async def test_servo_500_and_2500_us_when_the_limits_allow(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        servo = await board.servo(D9, min_us=500, max_us=2500)
        soft = await board.soft_pwm(D4, min_us=500, max_us=2500)
        for width in (500, 2500):
            await servo.set_pulse(width)
            await soft.set_pulse(width)
            for pin in ("D9", "D4"):
                stats = await fresh_pulses(uno, pin, 3)
                assert all(abs(h - width) <= 1 for h in stats.high_us[-2:]), (pin, stats)
        await servo.set_angle(180)  # the angle maps onto the configured limits
        stats = await fresh_pulses(uno, "D9", 3)
        assert all(abs(h - 2500) <= 1 for h in stats.high_us[-2:])


async def test_the_failsafe_stops_pwm_within_its_timeout(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    timeout_ms = 100
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        motor = await board.motor(D9, D7, D8, frequency_hz=20000)
        fan = await board.pwm(D6, 0.8, frequency_hz=7812)
        await motor.set_speed(0.7)
        await board.arm_failsafe(timeout_ms, {motor: 0, fan: 0.0})
        time.sleep(0.3)  # noqa: ASYNC251 - the host's event loop is stuck: no heartbeat
        # read while the loop is still stuck: once it runs, the keepalive polls again
        silent_from = float(control_now(uno, "status")["last_host_byte_us"])
        for pin in ("D9", "D6"):
            stats = await uno.pulse_stats(pin)  # the last fall: where the pin stopped
            assert stats.last_edge_us is not None and stats.level == 0, (pin, stats)
            assert silent_from < stats.last_edge_us <= silent_from + (timeout_ms + 20) * 1000
            assert await steady_level(uno, pin, 1000) == 0  # and no pulse since
        with anyio.fail_after(2):
            while not board.failsafe_tripped:  # noqa: ASYNC110 - the event is on its way
                await anyio.sleep(0.01)


def test_each_sweep_pin_is_on_the_timer_it_stands_for() -> None:
    assert all(TIMER_OF[pin] is timer for timer, pin in SWEEP_PINS.items())


# ---- the command line ----------------------------------------------------------------------


async def run_cli(*argv: str) -> tuple[int, str]:
    """Run ``arduinoio`` in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=200)
    code = await anyio.to_thread.run_sync(lambda: cli_main(list(argv), console=console))
    return code, buffer.getvalue()


async def test_cli_pwm_motor_and_the_wide_servo(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    code, out = await run_cli("pwm", "--port", uno.port, "D9", "0.4", "--freq", "31k")
    assert code == 0 and "31250 Hz" in out, out
    stats = await measured(uno, "D9")
    assert abs(statistics.median(stats.high_us) - 0.4 * 32) <= 1 / 16 + REPORTED_US
    code, _ = await run_cli("pwm", "--port", uno.port, "D5", "0.4", "--freq", "31k")
    assert code == 1 and "62500 Hz, 7812 Hz" in capsys.readouterr().err  # Timer0 has no 31k
    code, _ = await run_cli("release", "--port", uno.port, "D9")
    code, _ = await run_cli("servo", "--port", uno.port, "D9", "2400")
    assert code == 1 and "1000-2000" in capsys.readouterr().err  # the safe default
    code, _ = await run_cli("servo", "--port", uno.port, "D9", "2400", "--max-us", "2500")
    assert code == 0
    stats = await fresh_pulses(uno, "D9", 3)
    assert abs(stats.high_us[-1] - 2400) <= 1
    code, out = await run_cli("motor", "--port", uno.port, "D6", "D7", "D8", "--speed", "-0.5")
    assert code == 0 and "running -0.50" in out, out
    assert (await pin_level(uno, "D7"), await pin_level(uno, "D8")) == (0, 1)
    stats = await measured(uno, "D6")
    assert all(abs(h - 0.5 * 1024) <= 4 + REPORTED_US for h in stats.high_us[-6:])  # 976 Hz
