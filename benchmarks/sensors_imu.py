"""IMU in the stream on the virtual Uno: ``imu_stream_hz`` and ``imu_stream_lost``.

The sensing image at 1 Mbaud streams A0-A3 and an MPU-6050's 14 data bytes (one I2C
block read by the board at 400 kHz every period) at 1 kHz for ``--seconds`` of simulated
time (60 by default: 60,000 samples).  The oracle is the harness's MPU-6050 model
(firmware/sim/mpu6050.c): the bytes it served on each read, fetched while the stream runs
(its log ring holds 16,384 reads).  A sample is *lost* if it never arrived (a sequence
gap, a buffer drop), if its block is invalid (a bus error), or if its bytes differ from
the model's read of that period.  ``imu_stream_hz`` is samples per second of board time
(the samples' own timestamps).  Goal: 1,000 Hz with 0 lost.  Merged into
``sensors.json`` (keys ``imu``, ``imu_stream_hz``, ``imu_stream_lost``), the other keys
left as they are.

``--encoders`` adds two quadrature encoders and a sonar (D7/D8, 1,500 mm, fired every 40 ms)
to the same stream (D2/D3 on INT0/INT1, D4/D12 on
pin-change interrupts), each fed by the harness's quadrature generator at
``--encoder-rate`` edges/s for the whole run (one forwards, one backwards); their streamed
counts must end at the generators' positions (``encoder_count_error``, goal 0).  The keys
then go to ``sensors_all`` (``sensors_all_lost``), not ``imu``.

    .venv/bin/python -m benchmarks.sensors_imu --json benchmarks/results/sensors.json
    .venv/bin/python -m benchmarks.sensors_imu --encoders --json benchmarks/results/sensors.json
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path
from typing import Any

import anyio

from arduinoio_async import A0, A1, A2, A3, D2, D3, D4, D7, D8, D12, I2CSpeed
from arduinoio_async.board import Board
from arduinoio_async.board.i2c_blocks import block_errors
from arduinoio_async.board.imu import MPU6050
from arduinoio_async.sim import VirtualUno

from ._results import command_line, merge_result

GOAL_HZ = 1000
#: The sonar's target in the ``--encoders`` run (fired every 40 ms).
SONAR_MM = 1500
BATCH = 1000


async def served(uno: VirtualUno, first: int, count: int) -> list[bytes]:
    """``count`` reads the model logged from index ``first`` (waits until it has them)."""
    out: list[bytes] = []
    while len(out) < count:
        reply = await uno.command("imu_reads", **{"from": first + len(out), "count": 500})
        if reply["from"] != first + len(out):
            raise RuntimeError("the model's log ring overran: fetch more often")
        out += [bytes(data) for _, data in reply["reads"]][: count - len(out)]
        if len(out) < count:
            await anyio.sleep(0.05)
    return out


async def measure(baud: int, seconds: float, encoder_rate: int) -> dict[str, Any]:
    total = round(seconds * GOAL_HZ)
    edges = round(encoder_rate * seconds * 0.9)  # done before the last sample
    async with (
        VirtualUno(board_id=1, baud=baud, profile="sensing") as uno,
        Board.open(uno.port, baudrate=baud) as board,
    ):
        encoders = []
        if encoder_rate:
            for pin in ("D2", "D3", "D4", "D12"):
                await uno.drive(pin, 0)
            encoders = [await board.encoder(a=D2, b=D3), await board.encoder(a=D4, b=D12)]
            await uno.sonar("D7", "D8", distance_mm=SONAR_MM)
            await board.sonar(D7, D8)
            await board.sonar_timing(period_ms=40)
        imu = MPU6050(await board.i2c(I2CSpeed.KHZ_400))
        await imu.configure(accel_g=4, gyro_dps=500)
        first = (await uno.command("imu"))["logged"]
        last_counts: tuple[int, ...] = ()
        sonar_heard, sonar_error = 0, 0.0
        received = mismatched = invalid = 0
        t_first = t_last = 0
        wraps = 0
        async with board.stream(
            analog=[A0, A1, A2, A3],
            i2c=[imu.block],
            encoders=bool(encoders),
            sonars=bool(encoders),
            period_ms=1,
            buffer=10 * BATCH,
        ) as samples:
            batch: list[bytes | None] = []
            async for sample in samples:
                if received == 0:
                    t_first = sample.board_time_us
                elif sample.board_time_us < t_last:
                    wraps += 1
                t_last = sample.board_time_us
                received += 1
                if received == 1 and encoders:
                    await uno.quadrature("D2", "D3", edges=edges, rate=encoder_rate)
                    await uno.quadrature("D4", "D12", edges=edges, rate=encoder_rate, direction=-1)
                if sample.encoders is not None:
                    last_counts = sample.encoders
                if sample.sonars is not None:
                    reading = sample.sonars[0]
                    if reading.distance_mm is not None:
                        sonar_heard += 1
                        sonar_error = max(sonar_error, abs(reading.distance_mm - SONAR_MM))
                block = sample.i2c[0] if sample.i2c else None
                batch.append(block)
                if len(batch) == BATCH or received == total:
                    truth = await served(uno, first + received - len(batch), len(batch))
                    invalid += sum(b is None for b in batch)
                    mismatched += sum(
                        b is not None and b != t for b, t in zip(batch, truth, strict=True)
                    )
                    batch = []
                if received == total:
                    break
        gaps, dropped = samples.gaps, samples.dropped
        errors = await block_errors(board, 0)
        count_error = None
        if encoders:
            positions = {g.a: g.position for g in await uno.wait_quadrature()}
            streamed = [last_counts[e.slot] for e in encoders]
            count_error = sum(abs(c - positions[a]) for c, a in zip(streamed, (2, 4), strict=True))
    span_us = (t_last + wraps * 2**32 - t_first) or 1
    lost = gaps + dropped + invalid + mismatched
    return {
        "imu_stream_hz": round((received - 1) / span_us * 1e6, 3),
        "imu_stream_lost": lost,
        "imu_goal_hz": GOAL_HZ,
        "imu_goal_met": lost == 0 and (received - 1) / span_us * 1e6 >= GOAL_HZ * 0.999,
        "samples": received,
        "gaps": gaps,
        "dropped": dropped,
        "invalid_blocks": invalid,
        "mismatched_blocks": mismatched,
        "board_bus_errors": errors,
        **(
            {
                "encoder_rate_each": encoder_rate,
                "encoder_edges_each": edges,
                "encoder_count_error": count_error,
                "sonar_set_mm": SONAR_MM,
                "sonar_samples_with_a_reading": sonar_heard,
                "sonar_error_mm_max": sonar_error,
            }
            if encoders
            else {}
        ),
        "board_seconds": round(span_us / 1e6, 3),
        "clock": "board time (the samples' timestamps); the harness runs in simulated time",
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baud", type=int, default=1_000_000)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--encoders", action="store_true", help="two encoders in the stream too")
    parser.add_argument("--encoder-rate", type=int, default=5_000, help="edges/s per encoder")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    result = anyio.run(measure, args.baud, args.seconds, args.encoder_rate if args.encoders else 0)
    result = {
        "command": command_line(),
        "machine": platform.node(),
        "load_avg_at_start": load,
        "baud": args.baud,
        "load": "1 kHz stream: A0-A3 + one 14-byte MPU-6050 block at 400 kHz I2C (sensing image)"
        + (" + two quadrature encoders + a sonar" if args.encoders else ""),
        **result,
    }
    print(
        f"imu_stream_hz: {result['imu_stream_hz']}, imu_stream_lost: {result['imu_stream_lost']} "
        f"(goal {GOAL_HZ} Hz with 0 lost, met: {result['imu_goal_met']})"
        + (f", encoder_count_error: {result['encoder_count_error']}" if args.encoders else "")
    )
    if args.json:

        def update(data: dict[str, Any]) -> None:
            if args.encoders:
                data["sensors_all"] = result
                data["sensors_all_lost"] = result["imu_stream_lost"] + result["encoder_count_error"]
                return
            data["imu"] = result
            data["imu_stream_hz"] = result["imu_stream_hz"]
            data["imu_stream_lost"] = result["imu_stream_lost"]

        merge_result(args.json, update)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
