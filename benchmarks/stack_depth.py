"""The firmware's stack at its deepest under a heavy workload:
``stack_free_min_bytes``, the RAM the stack never reached.

The virtual Uno paints the free RAM below the stack pointer (``stack_paint``, from the
end of .bss as ``avr-size`` gives it), then the workload runs: four steppers at 10,000
steps/s with a limit switch closing, a 1 kHz stream carrying their positions, four tasks
pipelining GPIO writes, transactions, I2C reads of the fixture's EEPROM, an analog watch,
software and servo PWM, and a failsafe trip that stops everything; ``stack_low`` finds the
lowest byte the stack overwrote.  Goal: at least 400 B never reached.

    .venv/bin/python -m benchmarks.stack_depth --json benchmarks/results/motors.json

The JSON file is merged (:func:`benchmarks._results.merge_result`): the other
benchmarks' keys are kept.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import time
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import A0, D2, D3, D4, D5, D6, D7, D8, D9, D10, D12, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.harness import find_firmware_elf

from ._results import command_line, merge_result

RAM_START = 0x100


def bss_end(elf: Path) -> int:
    """First free RAM byte: .data and .bss start at 0x100 (``avr-size``)."""
    out = subprocess.run(["avr-size", str(elf)], check=True, capture_output=True, text=True)
    _text, data, bss, *_ = out.stdout.splitlines()[1].split()
    return RAM_START + int(data) + int(bss)


async def workload(uno: VirtualUno, board: Board, with_steppers: bool) -> None:
    pins = [(D2, D3), (D4, D5), (D6, D7), (D8, D12)] if with_steppers else []
    steppers = [
        await board.stepper(step=s, dir=d, max_speed=10_000, acceleration=200_000) for s, d in pins
    ]
    if steppers:
        await steppers[0].limit(D13, positive=True)
        await uno.command("step_log", pin="D2", enable=True)
        await uno.command("limit_at", pin="D2", after=3000, drive="D13", level=0)
    servo = await board.servo(D9, pulse_us=1500)
    led = await board.digital_output(D10)
    bus = await board.i2c()
    async with (
        board.analog(A0).watch(deadband=4) as _changes,
        board.stream(steppers=True, period_ms=1) as samples,
        anyio.create_task_group() as tg,
    ):

        async def drain() -> None:
            async for _ in samples:
                pass

        async def hammer() -> None:
            for i in range(300):
                await led.write(bool(i & 1))

        async def transactions() -> None:
            for _ in range(50):
                async with board.transaction() as tx:
                    tx.add(p.GpioWrite(int(D10), True))
                    tx.add(p.GpioRead(int(D10)))
                await bus.read(0x50, 0, 16)

        tg.start_soon(drain)
        for k, stepper in enumerate(steppers):
            await stepper.move_to(8000 if k % 2 else -8000)
        async with anyio.create_task_group() as load:
            for _ in range(4):
                load.start_soon(hammer)
            load.start_soon(transactions)
        await servo.set_pulse(1200)
        for stepper in steppers:
            await stepper.wait(timeout=30)
        if steppers:
            await steppers[1].run(5000)
        await board.arm_failsafe(100, {})
        time.sleep(0.3)  # noqa: ASYNC251 - the loop stalls on purpose: the failsafe trips
        tg.cancel_scope.cancel()


async def deepest(baud: int, with_steppers: bool) -> dict[str, Any]:
    start = bss_end(find_firmware_elf(baud))
    async with VirtualUno(board_id=1, baud=baud) as uno, Board.open(uno.port, baudrate=baud) as b:
        await uno.command("stack_paint", **{"from": start})
        await workload(uno, b, with_steppers)
        low: dict[str, Any] = await uno.command("stack_low", **{"from": start})
    return {**low, "from": start}


async def measure(baud: int) -> dict[str, Any]:
    full = await deepest(baud, True)
    bare = await deepest(baud, False)
    return {
        "stack_free_min_bytes": full["free_min"],
        "stack_free_min_bytes_without_steppers": bare["free_min"],
        "stack_deepest_address": full["lowest"],
        "stack_bss_end": full["from"],
        "stack_ramend": full["ramend"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = {
        "stack_command": command_line(),
        "stack_load_average": os.getloadavg()[0],
        **anyio.run(measure, args.baud),
    }
    print(
        f"stack_free_min_bytes: {result['stack_free_min_bytes']} (goal >= 400; without "
        f"steppers {result['stack_free_min_bytes_without_steppers']})"
    )
    if args.json:
        merge_result(args.json, lambda data: data.update(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
