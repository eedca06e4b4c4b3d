"""Steppers on the virtual Uno: ``max_step_rate_per_s`` and
``limit_stop_latency_us_max``.

Step rate: four steppers (step D2/D4/D6/D8) move 6,000 steps each at a top speed of
R steps/s (acceleration 200,000 steps/s^2) while a 1 kHz stream carries their positions
and four tasks pipeline GPIO writes to D10 at 1 Mbaud.  The fixture logs every step pulse
(firmware/sim/steps.c); a rate passes when every stepper made exactly its steps (0 lost,
0 extra), the board reports the target, and the measured cruise rate (steps over their
time, the ramps left out) is within 2 % of R.  ``max_step_rate_per_s`` is the largest
aggregate (4 R) that passes.  The clock is the simulated one: the step times are the
simulated cycle counter's, so a loaded host changes nothing but the wall time it takes.

Limit stop latency: a stepper runs at S steps/s toward a limit switch the fixture closes
at the instant of a step (``limit_at``); the latency is the time from the switch closing
to the board's stop, taken from the StepperDone timestamp (the board's clock) mapped to
simulated time through a move's last step and its StepperDone (both in the same tick);
the steps after the closing are counted too (must be 0 or 1, a step already on its way).

    .venv/bin/python -m benchmarks.motors_steppers --json benchmarks/results/motors.json

The JSON file is merged (:func:`benchmarks._results.merge_result`): the other
benchmarks' keys (``duty_error_ticks_max``, ``stack_*``...) are kept.
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D12, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.steppers import Stepper
from arduinoio_async.sim import VirtualUno

from ._results import command_line, merge_result

PINS = [(D2, D3), (D4, D5), (D6, D7), (D8, D9)]
RATES = (2500, 5000, 7500, 10000)  # per stepper
STEPS = 6000
ACCEL = 200_000
LIMIT_SPEEDS = (1000, 2500, 5000, 10000)


async def _times(uno: VirtualUno, pin: str) -> tuple[list[float], float | None]:
    times: list[float] = []
    while True:
        reply = await uno.command("steps", pin=pin, **{"from": len(times)})
        times += reply["times_us"]
        if len(times) >= reply["count"]:
            return times, reply["limit_us"]


async def rate_trial(
    uno: VirtualUno, board: Board, steppers: list[Stepper], rate: int
) -> dict[str, Any]:
    for stepper in steppers:
        await stepper.set_profile(rate, ACCEL)
        await stepper.set_position(0)
    for step, _ in PINS:
        await uno.command("step_log", pin=step.name, enable=True)
    led = await board.digital_output(D10)
    samples = 0
    async with board.stream(steppers=True, period_ms=1) as stream:

        async def count() -> None:
            nonlocal samples
            async for _ in stream:
                samples += 1

        async def hammer() -> None:
            for i in range(400):
                await led.write(bool(i & 1))

        async with anyio.create_task_group() as tg:
            tg.start_soon(count)
            for k, stepper in enumerate(steppers):
                await stepper.move_to(STEPS if k % 2 else -STEPS)
            async with anyio.create_task_group() as pipe:
                for _ in range(4):
                    pipe.start_soon(hammer)
            ends = [await s.wait(timeout=30) for s in steppers]
            tg.cancel_scope.cancel()
    await led.release()
    lost, cruise_rates = 0, []
    ramp = rate * rate // (2 * ACCEL) + 20
    for (step, _), end, k in zip(PINS, ends, range(4), strict=True):
        times, _ = await _times(uno, step.name)
        lost += abs(len(times) - STEPS) + abs(end.position - (STEPS if k % 2 else -STEPS))
        cruise = times[ramp : STEPS - ramp]
        cruise_rates.append((len(cruise) - 1) / ((cruise[-1] - cruise[0]) / 1e6))
    worst = max(abs(r - rate) / rate for r in cruise_rates)
    return {
        "rate_per_stepper": rate,
        "aggregate_per_s": 4 * rate,
        "lost_steps": lost,
        "cruise_rates": [round(r, 1) for r in cruise_rates],
        "cruise_error_pct_max": round(100 * worst, 3),
        "stream_samples": samples,
        "passes": lost == 0 and worst <= 0.02,
    }


async def limit_trial(
    uno: VirtualUno, board: Board, stepper: Stepper, speed: int, after: int
) -> dict[str, Any]:
    await stepper.set_profile(speed, ACCEL)
    await uno.command("drive", pin="D12", level=1)  # the switch open
    await uno.command("step_log", pin="D13", enable=True)
    # calibration: a move's last step and its StepperDone come from one tick
    await stepper.move_by(10)
    await stepper.wait(timeout=10)
    times, _ = await _times(uno, "D13")
    assert stepper.last_done is not None and stepper.last_done.reason is p.StepperDoneReason.TARGET
    offset_us = stepper.last_done.timestamp_us - times[-1]
    await uno.command("step_log", pin="D13", enable=True)
    await uno.command("limit_at", pin="D13", after=after, drive="D12", level=0)
    await stepper.run(speed)
    await stepper.wait(timeout=20)
    times, closed = await _times(uno, "D13")
    done = stepper.last_done
    assert closed is not None and done is not None and done.reason is p.StepperDoneReason.LIMIT_MAX
    await stepper.move_by(-after - 10)  # back off the switch
    await stepper.wait(timeout=20)
    return {
        "speed": speed,
        "step_period_us": 1e6 / speed,
        "latency_us": round(done.timestamp_us - offset_us - closed, 2),
        "steps_after_closing": sum(1 for t in times if t > closed),
    }


async def measure(baud: int) -> dict[str, Any]:
    async with (
        VirtualUno(board_id=1, baud=baud) as uno,
        Board.open(uno.port, baudrate=baud) as board,
    ):
        steppers = [await board.stepper(step=s, dir=d) for s, d in PINS]
        rates = [await rate_trial(uno, board, steppers, rate) for rate in RATES]
        for stepper in steppers:
            await stepper.release()
        stepper = await board.stepper(step=D13, dir=D3)
        await stepper.limit(D12, positive=True)
        limits = []
        for speed in LIMIT_SPEEDS:
            for after in (500, 777, 1001):
                limits.append(await limit_trial(uno, board, stepper, speed, after))
    passing = [r["aggregate_per_s"] for r in rates if r["passes"]]
    return {
        "max_step_rate_per_s": max(passing, default=0),
        "max_step_rate_clock": "simulated (the fixture's step times; firmware/sim/steps.c)",
        "step_rate_rows": rates,
        "limit_stop_latency_us_max": max(r["latency_us"] for r in limits),
        "limit_steps_after_closing_max": max(r["steps_after_closing"] for r in limits),
        "limit_rows": limits,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args.baud)
    result = {
        "steppers_command": command_line(),
        "steppers_machine": platform.node(),
        "steppers_load_average": os.getloadavg()[0],
        "steppers_baud": args.baud,
        "steppers_load": "1 kHz stream (positions) + 4 tasks of pipelined GPIO WRITE to D10",
        **result,
    }
    print(
        f"max_step_rate_per_s: {result['max_step_rate_per_s']} (goal >= 20000), "
        f"limit_stop_latency_us_max: {result['limit_stop_latency_us_max']}"
    )
    if args.json:
        merge_result(args.json, lambda data: data.update(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
