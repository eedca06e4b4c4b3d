"""Steppers and limit switches on the virtual Uno (issue 26 item 4).

Every oracle is the fixture's: each step pulse of the step pins logged with its simulated
time (firmware/sim/steps.c), a limit switch closed by the harness at an exact step, and
the direction pin's level; never the library's own answer.  Speeds and accelerations are
in simulated time, the board's own clock.
"""

from __future__ import annotations

import io
import itertools
import time

import anyio
import pytest
from anyio.from_thread import start_blocking_portal
from rich.console import Console

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11
from arduinoio_async import protocol as p
from arduinoio_async.blocking import open_board
from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import PinRoleError
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.harness import SimulatorNotAvailable
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import control_now
from .steps import fit_quadratic, quiet_steps, step_log, step_times

pytestmark = pytest.mark.sim

BAUD = 1_000_000


async def test_a_10000_step_move_ends_exactly_at_its_target_with_the_requested_profile(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    speed, accel, target = 4000, 8000, 10_000
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        stepper = await board.stepper(step=D2, dir=D3, max_speed=speed, acceleration=accel)
        await step_log(uno, "D2")
        assert await stepper.move_to(target) == target
        state = await stepper.wait(timeout=20)
        times, _ = await step_times(uno, "D2")
        assert len(times) == target  # the fixture counted every pulse: none lost, none extra
        assert state.position == target and not state.moving
        assert stepper.last_done is not None
        assert stepper.last_done.reason is p.StepperDoneReason.TARGET
        assert (await uno.pin("D3")).level == 1  # positive: the direction pin high
    # peak speed: the cruise between the ramps (1,000 steps each: v^2 / 2a)
    ramp = speed**2 // (2 * accel)
    cruise = times[ramp + 500 : target - ramp - 500]
    peak = (len(cruise) - 1) / ((cruise[-1] - cruise[0]) / 1e6)
    assert abs(peak - speed) <= 0.02 * speed, peak
    # acceleration: the step count against time along the ramp up is a t^2 / 2
    up = [t / 1e6 for t in times[50 : ramp - 50]]
    _, _, half_a = fit_quadratic(up, [float(n) for n in range(50, ramp - 50)])
    assert abs(2 * half_a - accel) <= 0.02 * accel, 2 * half_a
    down = [t / 1e6 for t in times[target - ramp + 50 : target - 50]]
    _, _, half_d = fit_quadratic(down, [float(n) for n in range(target - ramp + 50, target - 50)])
    assert abs(-2 * half_d - accel) <= 0.02 * accel, -2 * half_d
    # one step a tick at most
    assert min(b - a for a, b in itertools.pairwise(times)) >= 99.0


async def test_no_step_is_lost_while_a_1khz_stream_and_pipelined_commands_run(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    pins = [(D2, D3), (D4, D5), (D6, D7), (D8, D9)]
    targets = [6000, -6000, 5000, -5000]
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        steppers = [
            await board.stepper(step=s, dir=d, max_speed=5000, acceleration=50_000) for s, d in pins
        ]
        led = await board.digital_output(D10)
        await step_log(uno, *(s.name for s, _ in pins))
        seen: list[tuple[int, ...]] = []
        async with board.stream(steppers=True, period_ms=1) as samples:

            async def collect() -> None:
                async for sample in samples:
                    assert sample.steppers is not None
                    seen.append(sample.steppers)

            async def hammer() -> None:
                for i in range(600):
                    await led.write(bool(i & 1))

            async with anyio.create_task_group() as tg:
                tg.start_soon(collect)
                for stepper, target in zip(steppers, targets, strict=True):
                    await stepper.move_to(target)
                async with anyio.create_task_group() as pipe:
                    for _ in range(4):
                        pipe.start_soon(hammer)
                for stepper in steppers:
                    await stepper.wait(timeout=20)
                tg.cancel_scope.cancel()
        for (step, _), stepper, target in zip(pins, steppers, targets, strict=True):
            times, _ = await step_times(uno, step.name)
            assert len(times) == abs(target), step  # the fixture's count: every step made
            assert (await stepper.read()).position == target
    assert len(seen) > 500  # the stream ran meanwhile
    for slot, target in enumerate(targets):
        trail = [s[slot] for s in seen]
        assert all(abs(b) >= abs(a) for a, b in itertools.pairwise(trail))
        assert all(abs(v) <= abs(target) for v in trail)


async def test_a_limit_switch_stops_the_stepper_within_one_step_period(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    speed = 5000  # a step every 200 us
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        stepper = await board.stepper(step=D2, dir=D3, max_speed=speed, acceleration=100_000)
        await stepper.limit(D4, positive=True)  # a switch to ground: closed = low
        await step_log(uno, "D2")
        await uno.command("limit_at", pin="D2", after=3000, drive="D4", level=0)
        await stepper.run(speed)
        state = await stepper.wait(timeout=10)
        times, closed_us = await step_times(uno, "D2")
        assert closed_us is not None
        after = [t for t in times if t > closed_us]
        assert len(after) <= 1 and all(t - closed_us <= 1e6 / speed for t in after), after
        assert await quiet_steps(uno, "D2", 2000) == len(times)
        assert state.position == len(times) and state.limit_max
        assert stepper.last_done is not None
        assert stepper.last_done.reason is p.StepperDoneReason.LIMIT_MAX
        assert stepper.last_done.position == len(times)
        # into the closed switch: not one step; away from it: moves
        await stepper.move_by(100)
        assert (await stepper.wait(timeout=5)).position == len(times)
        await stepper.move_by(-100)
        assert (await stepper.wait(timeout=5)).position == len(times) - 100


async def test_homing_runs_to_the_switch_and_calls_it_zero(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        stepper = await board.stepper(step=D6, dir=D7, max_speed=3000, acceleration=30_000)
        await stepper.limit(D11)
        await step_log(uno, "D6")
        await uno.command("limit_at", pin="D6", after=1234, drive="D11", level=0)
        assert await stepper.home(2000, timeout=10) == 1234
        assert (await stepper.read()).position == 0
        assert (await uno.pin("D7")).level == 0  # it ran negative
        await stepper.move_to(50)
        assert (await stepper.wait(timeout=5)).position == 50


async def test_the_failsafe_stops_every_stepper_within_its_timeout(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    timeout_ms = 100
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        one = await board.stepper(step=D2, dir=D3, max_speed=2000, acceleration=20_000)
        two = await board.stepper(step=D4, dir=D5, max_speed=3000, acceleration=20_000)
        await step_log(uno, "D2", "D4")
        await one.run(2000)
        await two.run(-3000)
        await board.arm_failsafe(timeout_ms, {})
        time.sleep(0.4)  # noqa: ASYNC251 - the host's event loop is stuck: no heartbeat
        silent_from = float(control_now(uno, "status")["last_host_byte_us"])
        for pin in ("D2", "D4"):
            times, _ = await step_times(uno, pin)
            assert times and times[-1] <= silent_from + (timeout_ms + 20) * 1000, pin
            assert await quiet_steps(uno, pin, 2000) == len(times)
        with anyio.fail_after(2):
            while not board.failsafe_tripped:  # noqa: ASYNC110 - the event is on its way
                await anyio.sleep(0.01)
        assert one.last_done is not None
        assert one.last_done.reason is p.StepperDoneReason.FAILSAFE


async def test_pin_roles_refuse_a_stepper_pin_with_words_naming_the_stepper(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=BAUD)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        stepper = await board.stepper(step=D2, dir=D3)
        await stepper.limit(D4)
        with pytest.raises(PinRoleError, match="stepper 0's direction pin"):
            await board.digital_output(D3)
        with pytest.raises(PinRoleError, match="stepper 0's negative limit switch"):
            await board.stepper(step=D5, dir=D4)
        await stepper.release()
        out = await board.digital_output(D3)  # free again, on the board too
        await out.write(True)
        assert (await uno.pin("D3")).level == 1


# ---- the command line and the blocking API ---------------------------------------------------


async def run_cli(*argv: str) -> tuple[int, str]:
    """Run ``arduinoio`` in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=200)
    code = await anyio.to_thread.run_sync(lambda: cli_main(list(argv), console=console))
    return code, buffer.getvalue()


async def test_cli_moves_a_stepper_and_refuses_homing_without_a_switch(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(baud=BAUD)
    await step_log(uno, "D2")
    port = ("--port", uno.port)
    code, out = await run_cli("stepper", *port, "D2", "D3", "--by", "-700", "--speed", "3000")
    assert code == 0 and "position -700 (target)" in out, out
    times, _ = await step_times(uno, "D2")
    assert len(times) == 700
    assert (await uno.pin("D3")).level == 0
    code, _ = await run_cli("stepper", *port, "D2", "D3", "--home")
    assert code == 1 and "--home needs the switch" in capsys.readouterr().err


def test_a_script_moves_a_stepper_with_the_blocking_api() -> None:
    with start_blocking_portal() as portal:
        try:
            cm = portal.wrap_async_context_manager(VirtualUno(board_id=0x0035, baud=BAUD))
            uno = cm.__enter__()
        except SimulatorNotAvailable as exc:
            pytest.skip(f"virtual Uno not available: {exc}")
        try:
            portal.call(step_log, uno, "D4")
            with open_board(uno.port) as board:
                stepper = board.stepper(step=D4, dir=D5, max_speed=4000, acceleration=40_000)
                assert stepper.move_to(1500) == 1500
                assert stepper.move_by(-500) == 1000
                stepper.set_position(0)
                assert stepper.read().position == 0
                stepper.release()
            times, _ = portal.call(step_times, uno, "D4")
        finally:
            cm.__exit__(None, None, None)
    assert len(times) == 2000
