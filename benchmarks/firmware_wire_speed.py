"""Pipelined GPIO WRITE through the virtual Uno's pty.

The host keeps ``--window`` write-pin requests in flight (raw pyserial, no library, so
the host is never the limit) and counts simulated CPU cycles with the harness's
``status.cycle``.  While the firmware is the bottleneck it never sleeps, and the cycles
per command are its whole work per command: five receive interrupts, parsing,
execution, the reply, five transmit interrupts and its share of the timer interrupts.
When it is faster than the wire the number is the wire time instead (simavr moves 11 bit
times per byte: 880 cycles per 5-byte command at 1 Mbaud, 440 at 2 Mbaud), so the
firmware's own figure shows at 2 Mbaud.

Several ELFs (e.g. before and after a change) are measured interleaved, round after
round, and reported as medians with their spread, because the machine is shared.  The
host (pyserial, the pty hops) must keep the window full for the figure to be the
firmware's; on a loaded machine it is not, and the exact, host-free count is
``benchmarks/firmware_cycles.py``.

    .venv/bin/python -m benchmarks.firmware_wire_speed --elf old=/tmp/old.elf \\
        --elf new=firmware/build/arduinoio-2000000.elf --baud 2000000 --rounds 5
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import anyio
import serial

from arduinoio_async import protocol as p
from arduinoio_async.sim import VirtualUno

from ._results import command_line, write_result

PIN = 13


def _pipeline(port: str, baud: int, n: int, window: int) -> float:
    """Send n write-pin requests keeping ``window`` in flight; check every reply."""
    request = [p.GpioWrite(PIN, bool(i & 1)).encode() for i in range(2)]
    reply = [p.GpioWriteReply(PIN, bool(i & 1)).encode() for i in range(2)]
    size = len(request[0])
    with serial.Serial(port, baud, timeout=0.5) as link:
        config = p.GpioConfig(PIN, p.GpioFlags.OUTPUT).encode()
        for _attempt in range(20):  # the firmware may still be starting its UART
            link.write(config)
            if link.read(len(config)) == config:
                break
            link.reset_input_buffer()
        else:
            raise RuntimeError("no reply to GPIO CONFIG")
        link.timeout = 2
        sent = received = 0
        start = time.perf_counter()
        while received < n:
            room = min(window - (sent - received), n - sent)
            if room > 0:
                link.write(b"".join(request[(sent + i) & 1] for i in range(room)))
                sent += room
            waiting = max(size, link.in_waiting // size * size)
            data = link.read(waiting)
            if len(data) != waiting:
                raise RuntimeError(f"reply timeout after {received} of {n}")
            for i in range(0, waiting, size):
                if data[i : i + size] != reply[received & 1]:
                    raise RuntimeError(f"bad reply {data[i : i + size].hex()} at {received}")
                received += 1
        return time.perf_counter() - start


async def measure(elf: Path, baud: int, n: int, window: int) -> dict[str, Any]:
    async with VirtualUno(baud=baud, elf=elf) as uno:
        await anyio.to_thread.run_sync(_pipeline, uno.port, baud, 200, window)  # warm up
        before = await uno.status()
        wall = await anyio.to_thread.run_sync(_pipeline, uno.port, baud, n, window)
        after = await uno.status()
    cycles = after["cycle"] - before["cycle"]
    return {
        "cycles_per_command": cycles / n,
        "simulated_per_s": n * 16e6 / cycles,
        "wall_per_s": n / wall,
        "rebases": after["rebases"] - before["rebases"],
    }


def _spread(values: list[float]) -> dict[str, float]:
    return {
        "median": round(statistics.median(values), 1),
        "min": round(min(values), 1),
        "max": round(max(values), 1),
    }


async def main(args: argparse.Namespace) -> None:
    elfs = dict(item.split("=", 1) for item in args.elf)
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in elfs}
    for _ in range(args.rounds):
        for name, path in elfs.items():
            runs[name].append(await measure(Path(path), args.baud, args.n, args.window))
            print(name, json.dumps(runs[name][-1]), flush=True)
    summary = {
        name: {
            key: _spread([r[key] for r in results])
            for key in ("cycles_per_command", "simulated_per_s", "wall_per_s")
        }
        | {"rebases": sum(r["rebases"] for r in results)}
        for name, results in runs.items()
    }
    print(json.dumps(summary, indent=1))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_result(
            args.json,
            {
                "command": command_line(),
                "baud": args.baud,
                "n": args.n,
                "window": args.window,
                "elfs": elfs,
                "summary": summary,
                "runs": runs,
            },
        )


if __name__ == "__main__":
    import sys

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elf", action="append", required=True, help="NAME=PATH, repeatable")
    parser.add_argument("--baud", type=int, default=2_000_000)
    parser.add_argument("--n", type=int, default=5000)
    parser.add_argument("--window", type=int, default=24, help="requests in flight")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", type=Path)
    arguments = parser.parse_args()
    arguments.argv = sys.argv[1:]
    anyio.run(main, arguments)
