"""RC pulse-width accuracy on the virtual Uno's sensing image: ``rc_error_us_max``.

Four pulse inputs (D4, D7, D8, D12) read four RC sources of the harness
(firmware/sim/rcpulse.c) at 50 Hz, their widths stepped together through 1,000-2,000 us
(each channel offset, so the four edges do not coincide), while an encoder on D2/D3 turns
at 5,000 edges/s by default (``--encoder-rate``; its INT0/INT1 interrupts delay the
pulses' edges: the stamp is taken when the pin-change vector runs, not at the edge, so
a few microseconds of interrupt latency remain; a one-tick (100 us) error was the clock race
clock.c's tick vector now closes).
For each step, once every source has completed two pulses at the new width, each input is
read; the error is the board's width minus the width the source held the pin high
(``rcpulse_status``'s ``last_width_us``, measured in CPU cycles).  The maximum over every
step and channel is the result; ``sensors.json`` keeps the other sensor benchmarks' keys.
Sonar: ``benchmarks/sensors_sonar.py`` (``sonar_error_mm_max``).

    .venv/bin/python -m benchmarks.sensors_pulse --json benchmarks/results/sensors.json
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import D2, D3, D4, D7, D8, D12
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim import VirtualUno

from ._results import command_line, merge_result

PINS = (D4, D7, D8, D12)
PERIOD_US = 20_000


async def measure(
    step_us: int, encoder_rate: int, pins: tuple[DigitalPin, ...] = PINS, show: float = 0.0
) -> dict[str, Any]:
    async with (
        VirtualUno(profile="sensing") as uno,
        Board.open(uno.port, baudrate=uno.baud) as board,
    ):
        inputs = [await board.pulse_input(pin, timeout_ms=100) for pin in pins]
        if encoder_rate:
            await uno.drive("D2", 0)
            await uno.drive("D3", 0)
            await board.encoder(D2, D3)
            await uno.quadrature(
                "D2", "D3", edges=10**7, rate=encoder_rate, reverse=0.01, jitter=0.2
            )
        errors: list[float] = []
        worst: dict[str, Any] = {}
        for base in range(1000, 2001, step_us):
            widths = [min(2000, base + 7 * k) for k in range(len(pins))]
            for pin, width in zip(pins, widths, strict=True):
                await uno.rcpulse(pin.name, width_us=width, period_us=PERIOD_US)
            start = {s.pin: s.pulses for s in await uno.rcpulse_status()}
            with anyio.fail_after(30):
                while True:
                    sources = await uno.rcpulse_status()
                    if all(s.pulses >= start[s.pin] + 2 for s in sources):
                        break
                    await anyio.sleep(0.005)
            for handle, width in zip(inputs, widths, strict=True):
                state = await handle.read()
                truth = next(s for s in await uno.rcpulse_status() if s.pin == int(handle.pin))
                error = abs(state.width_us - truth.last_width_us)
                if show and error > show:  # signed: + a late fall, - a late rise
                    signed = state.width_us - truth.last_width_us
                    print(f"{handle.pin.name} set {width} us: board - truth {signed:+.3f} us")
                errors.append(error)
                if error >= max(errors):
                    worst = {
                        "pin": handle.pin.name,
                        "set_us": width,
                        "board_us": state.width_us,
                        "truth_us": truth.last_width_us,
                    }
        await uno.rcpulse_stop()
        await uno.quadrature_stop()
        return {
            "rc_samples": len(errors),
            "rc_error_us_max": max(errors),
            "rc_error_us_mean": round(sum(errors) / len(errors), 3),
            "rc_worst": worst,
        }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step-us", type=int, default=50)
    parser.add_argument("--encoder-rate", type=int, default=5_000, help="edges/s, 0: none")
    parser.add_argument(
        "--pins",
        default="D4 D7 D8 D12",
        help="the inputs, from D4 D7 D8 D12 (one: no channel beside)",
    )
    parser.add_argument("--show", type=float, default=0.0, help="print each read off by more (us)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    pins = tuple(pin for pin in PINS if pin.name in args.pins.split())
    result = anyio.run(measure, args.step_us, args.encoder_rate, pins, args.show)
    result = {
        "command": command_line(),
        "machine": platform.node(),
        "load_avg_at_start": os.getloadavg()[0],
        "load": f"{len(pins)} RC channels at 50 Hz + an encoder on D2/D3 at "
        f"{args.encoder_rate} edges/s",
        "clock": "simulated time (the harness's sources); widths by CPU cycles",
        **result,
    }
    print(f"rc_error_us_max: {result['rc_error_us_max']} over {result['rc_samples']} reads")
    if args.json:

        def update(data: dict[str, Any]) -> None:
            data["pulse_in"] = result
            data["rc_error_us_max"] = result["rc_error_us_max"]

        merge_result(args.json, update)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
