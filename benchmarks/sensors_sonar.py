"""Sonar accuracy on the virtual Uno's sensing image: ``sonar_error_mm_max``.

Four sonars (trigger/echo D4/D5, D6/D7, D8/D9, D10/D11) face four HC-SR04 models of the
harness (firmware/sim/sonar_model.c), their distances stepped together through 20-4,000 mm
(each sonar offset, so the echoes never end together), fired in turn by the board every
``--period-ms``, while an encoder on D2/D3 turns at 5,000 edges/s (``--encoder-rate``;
its interrupts delay the echo's edge stamps by a few microseconds: 1 us is 0.17 mm) and a
1 kHz stream carries the encoder counts and the sonars at 1 Mbaud.  For each step, once
every model has answered two firings at the new distance, each sonar is read; the error
is the board's distance minus the distance the model was set to (its echo widths are
exact to the CPU cycle).  The maximum over every step and sonar is the result, with the
models' overlap count (a trigger while another sonar's ping could be heard: must be 0)
and the stream's gaps; ``sensors.json`` keeps the other sensor benchmarks' keys.

    .venv/bin/python -m benchmarks.sensors_sonar --json benchmarks/results/sensors.json
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno

from ._results import command_line, merge_result

PINS = ((D4, D5), (D6, D7), (D8, D9), (D10, D11))


async def measure(step_mm: int, encoder_rate: int, period_ms: int) -> dict[str, Any]:
    async with (
        VirtualUno(profile="sensing", baud=1_000_000) as uno,
        Board.open(uno.port, baudrate=uno.baud) as board,
    ):
        for trigger, echo in PINS:
            await uno.sonar(int(trigger), int(echo), distance_mm=1000)
        sonars = [await board.sonar(trigger, echo) for trigger, echo in PINS]
        await board.sonar_timing(period_ms=period_ms)
        if encoder_rate:
            await uno.drive("D2", 0)
            await uno.drive("D3", 0)
            await board.encoder(D2, D3)
            await uno.quadrature(
                "D2", "D3", edges=10**8, rate=encoder_rate, reverse=0.01, jitter=0.2
            )
        errors: list[float] = []
        worst: dict[str, Any] = {}
        samples = 0
        async with board.stream(encoders=True, sonars=True, period_ms=1) as stream:

            async def consume() -> None:
                nonlocal samples
                async for _ in stream:
                    samples += 1

            async with anyio.create_task_group() as tg:
                tg.start_soon(consume)
                for base in range(20, 4001, step_mm):
                    distances = [min(4000, base + 37 * k) for k in range(len(PINS))]
                    for (trigger, _), distance in zip(PINS, distances, strict=True):
                        await uno.sonar(int(trigger), distance_mm=distance)
                    start = {s.trigger: s.echoes for s in (await uno.sonar_status()).sonars}
                    with anyio.fail_after(30):
                        while True:
                            status = await uno.sonar_status()
                            if all(s.echoes >= start[s.trigger] + 2 for s in status.sonars):
                                break
                            await anyio.sleep(0.005)
                    for sonar, distance in zip(sonars, distances, strict=True):
                        reading = await sonar.read()
                        got = reading.distance_mm if reading.distance_mm is not None else -1
                        error = abs(got - distance)
                        errors.append(error)
                        if error >= max(errors):
                            worst = {
                                "trigger": sonar.pin.name,
                                "set_mm": distance,
                                "board_mm": reading.distance_mm,
                                "board_echo_us": reading.echo_us,
                            }
                tg.cancel_scope.cancel()
        status = await uno.sonar_status()
        await uno.quadrature_stop()
        return {
            "sonar_samples": len(errors),
            "sonar_error_mm_max": max(errors),
            "sonar_error_mm_mean": round(sum(errors) / len(errors), 3),
            "sonar_worst": worst,
            "sonar_overlaps": status.overlaps,
            "sonar_stream_samples": samples,
            "sonar_stream_gaps": stream.gaps,
        }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step-mm", type=int, default=100)
    parser.add_argument("--encoder-rate", type=int, default=5_000, help="edges/s, 0: none")
    parser.add_argument("--period-ms", type=int, default=1, help="ms between firings")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = anyio.run(measure, args.step_mm, args.encoder_rate, args.period_ms)
    result = {
        "command": command_line(),
        "machine": platform.node(),
        "load_avg_at_start": os.getloadavg()[0],
        "load": (
            f"4 sonars in turn every {args.period_ms} ms + an encoder on D2/D3 at "
            f"{args.encoder_rate} edges/s + a 1 kHz stream (encoders, sonars) at 1 Mbaud"
        ),
        "clock": "simulated time (the harness's models); echo widths by CPU cycles",
        **result,
    }
    print(
        f"sonar_error_mm_max: {result['sonar_error_mm_max']} over {result['sonar_samples']} "
        f"reads (overlaps {result['sonar_overlaps']}, stream gaps {result['sonar_stream_gaps']})"
    )
    if args.json:

        def update(data: dict[str, Any]) -> None:
            data["sonar"] = result
            data["sonar_error_mm_max"] = result["sonar_error_mm_max"]

        merge_result(args.json, update)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
