"""The firmware's stack at its deepest under a heavy workload:
``stack_free_min_bytes``, the RAM the stack never reached.

Measured for every Uno image (docs/firmware-profiles.md), each under the heaviest load its
classes allow.  The virtual Uno paints the free RAM below the stack pointer
(``stack_paint``, from the end of .bss as ``avr-size`` gives it), then the workload runs:
on an image with steppers, four of them at 10,000 steps/s with a limit switch closing; on
one with encoders, two of them (INT0/INT1 and pin-change pins) fed 5,000 edges/s each by
the harness's quadrature generators; on the sensing image also two RC inputs fed 50 Hz
pulses, a sonar firing every 10 ms and the MPU-6050's register block in every sample;
then for every image a 1 kHz stream carrying their positions or counts, four tasks
pipelining GPIO writes, transactions, I2C reads of the fixture's EEPROM, an analog watch,
servo PWM, and a failsafe trip that stops everything; ``stack_low`` finds the lowest byte
the stack overwrote.  Goal: at least 400 B never reached, on every image.

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
from arduinoio_async.board.imu import MPU6050
from arduinoio_async.protocol.profiles import UNO_PROFILES, Profile, profile
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.harness import find_firmware_elf

from ._results import command_line, merge_result

RAM_START = 0x100


def image_size(elf: Path) -> tuple[int, int, int]:
    """text, data and bss of an image (``avr-size``: bss includes the UART rings' .noinit
    at 0x100); RAM in use ends at 0x100 + data + bss."""
    out = subprocess.run(["avr-size", str(elf)], check=True, capture_output=True, text=True)
    text, data, bss = (int(x) for x in out.stdout.splitlines()[1].split()[:3])
    return text, data, bss


async def workload(uno: VirtualUno, board: Board, image: Profile) -> None:
    with_steppers, with_encoders = image.has("STEPPER"), image.has("ENCODER")
    # encoders on D2/D3 (INT0/INT1) and D8/D12 (pin-change); steppers on the rest
    if not with_steppers:
        pins = []
    elif with_encoders:
        pins = [(D4, D5), (D6, D7)]
    else:
        pins = [(D2, D3), (D4, D5), (D6, D7), (D8, D12)]
    steppers = [
        await board.stepper(step=s, dir=d, max_speed=10_000, acceleration=200_000) for s, d in pins
    ]
    if steppers:
        first = pins[0][0].name
        await steppers[0].limit(D13, positive=True)
        await uno.command("step_log", pin=first, enable=True)
        await uno.command("limit_at", pin=first, after=3000, drive="D13", level=0)
    if with_encoders:
        for a, b in (("D2", "D3"), ("D8", "D12")):
            await uno.drive(a, 0)
            await uno.drive(b, 0)
        await board.encoder(D2, D3)
        await board.encoder(D8, D12)
        for a, b in (("D2", "D3"), ("D8", "D12")):
            await uno.quadrature(a, b, edges=30_000, rate=5_000, reverse=0.01, jitter=0.2)
    # The sensing image's other timed inputs, all at once: two RC inputs (pin-change
    # stamps), a sonar firing every 10 ms, and the MPU-6050's block read by the TWI
    # interrupt every stream period.
    pulse_inputs = image.has("PULSE_IN") and not with_steppers
    sonars = image.has("SONAR") and not with_steppers
    for pin in (D4, D5) if pulse_inputs else ():
        await uno.rcpulse(pin.name, width_us=1500)
        await board.pulse_input(pin)
    if sonars:
        await uno.sonar("D6", "D7", distance_mm=1000)
        await board.sonar(D6, D7)
        await board.sonar_timing(period_ms=10)
    servo = await board.servo(D9, pulse_us=1500)
    led = await board.digital_output(D10)
    bus = await board.i2c(p.I2CSpeed.KHZ_400)
    blocks = [MPU6050(bus).block] if image.has("I2C_STREAM") else []
    if blocks:
        await MPU6050(bus).configure()
    async with (
        board.analog(A0).watch(deadband=4) as _changes,
        board.stream(
            steppers=with_steppers,
            encoders=with_encoders and not with_steppers,
            sonars=sonars,
            pulse_inputs=pulse_inputs,
            i2c=blocks,
            period_ms=1,
        ) as samples,
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
                if not blocks:  # with blocks in the stream, the bus is the stream's
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


async def deepest(baud: int, name: str) -> dict[str, Any]:
    text, data, bss = image_size(find_firmware_elf(baud, name))
    start = RAM_START + data + bss
    image = profile(name)
    async with (
        VirtualUno(board_id=1, baud=baud, profile=name) as uno,
        Board.open(uno.port, baudrate=baud) as b,
    ):
        await uno.command("stack_paint", **{"from": start})
        await workload(uno, b, image)
        low: dict[str, Any] = await uno.command("stack_low", **{"from": start})
    return {
        "stack_free_min_bytes": low["free_min"],
        "stack_deepest_address": low["lowest"],
        "stack_bss_end": start,
        "stack_ramend": low["ramend"],
        "flash_bytes": text + data,
        "static_ram_bytes": data + bss,
    }


async def measure(baud: int, names: list[str]) -> dict[str, Any]:
    profiles = {name: await deepest(baud, name) for name in names}
    return {
        "stack_free_min_bytes": min(p["stack_free_min_bytes"] for p in profiles.values()),
        "stack_profiles": profiles,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--json", type=Path)
    parser.add_argument(
        "--profile", action="append", choices=UNO_PROFILES, help="one image (default: all)"
    )
    args = parser.parse_args()
    result = {
        "stack_command": command_line(),
        "stack_load_average": os.getloadavg()[0],
        **anyio.run(measure, args.baud, args.profile or list(UNO_PROFILES)),
    }
    for name, figures in result["stack_profiles"].items():
        print(
            f"{name}: stack never reached {figures['stack_free_min_bytes']} B (goal >= 400), "
            f"flash {figures['flash_bytes']} B, static RAM {figures['static_ram_bytes']} B"
        )
    if args.json:
        merge_result(args.json, lambda data: data.update(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
