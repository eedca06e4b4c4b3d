"""Duty-cycle PWM accuracy on the virtual Uno: ``duty_error_ticks_max``.

For every frequency each timer offers (D5: Timer0, D9: Timer1, D3: Timer2) and duties of
1, 37, 50 and 99 %, the fixture captures the pin's edges (simulated cycle counter) while
the host pipelines GPIO writes to a pin of the other port as fast as the link takes them
(D4 while D9 is measured, D13 while D5 or D3 is), and the error of
every captured high time against the requested duty is counted in timer ticks (the
rounding to the timer's counts included: the request is a 16-bit fraction).  Hardware
PWM does not depend on the CPU, so the error stays within the rounding plus the fixture's
edge-stamp resolution (firmware/sim/README.md) under any command load.

Why the other port: simavr 1.6 re-drives every output pin of a port with its PORT bit
on any write to that port (``avr_ioport_update_irqs``), which on the simulated Uno forces
a timer-driven pin low until its next compare edge; silicon's compare output overrides
PORT and has no such glitch.  The first run, with the writes on D13, measured that
simulator artifact on D9 (errors of hundreds of ticks), not the firmware.

    .venv/bin/python -m benchmarks.motors_duty --json benchmarks/results/motors.json

The JSON file is merged (:func:`benchmarks._results.merge_result`): the steppers' keys
(``motors_steppers``, ``stack_depth``) are kept.
"""

from __future__ import annotations

import argparse
import platform
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D3, D4, D5, D9, D13
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import DigitalPin, DutyPwmPin
from arduinoio_async.protocol.timers import DUTY_FREQUENCIES, TIMER_OF, timer_setting
from arduinoio_async.sim import VirtualUno

from ._results import command_line, merge_result

PINS: tuple[DutyPwmPin, ...] = (D5, D9, D3)
DUTIES = (0.01, 0.37, 0.5, 0.99)


async def hammer(board: Board, pin: DigitalPin, stop: anyio.Event) -> None:
    """Pipelined GPIO writes to ``pin`` until ``stop``: the command load the PWM runs under."""
    led = await board.digital_output(pin)
    while not stop.is_set():
        async with anyio.create_task_group() as tg:
            for i in range(8):
                tg.start_soon(led.write, bool(i & 1))
    await led.release()


async def measure(baud: int) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    async with (
        VirtualUno(board_id=1, baud=baud) as uno,
        Board.open(uno.port, baudrate=baud) as board,
    ):
        for pin in PINS:
            stop = anyio.Event()
            async with anyio.create_task_group() as tg:
                tg.start_soon(hammer, board, D4 if pin is D9 else D13, stop)
                timer = TIMER_OF[pin]
                for hz in DUTY_FREQUENCIES[timer]:
                    handle = await board.pwm(pin, frequency_hz=hz)
                    tick = timer_setting(timer, hz).prescaler / 16.0
                    for duty in DUTIES:
                        await handle.set_duty(duty)
                        await uno.clear_pulse_stats(pin.name)
                        with anyio.fail_after(20):
                            while (stats := await uno.pulse_stats(pin.name)).highs < 9:  # noqa: ASYNC110 - remote
                                await anyio.sleep(0.01)
                        want = duty * handle.steps * tick
                        errors = [abs(h - want) / tick for h in stats.high_us[-8:]]
                        rows.append(
                            {"pin": pin.name, "hz": hz, "duty": duty, "ticks_max": max(errors)}
                        )
                    await handle.release()
                stop.set()
    return {
        "duty_error_ticks_max": round(max(r["ticks_max"] for r in rows), 3),
        "rows": rows,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args.baud)
    result = {
        "command": command_line(),
        "machine": platform.node(),
        "baud": args.baud,
        "load": "pipelined GPIO WRITE, 8 in flight, to D4 (D9 measured) or D13 (D5, D3)",
        **result,
    }
    print(f"duty_error_ticks_max: {result['duty_error_ticks_max']} over {len(result['rows'])}")
    if args.json:
        merge_result(args.json, lambda data: data.update(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
