"""RC width error by stamping path on a bare ATmega328P in simavr: ``rc_capture``.

Why: choosing how the firmware times an RC pulse (issue 27 item 4: within 2 us) needs the
error of each path under the same interrupt load, apart from the rest of the firmware.
Two small AVR programs (``benchmarks/rc_capture/``) time pulses on D8 (PB0, ICP1):

* ``capture``: Timer1 input capture (ICR1 latched by the hardware at the edge);
* ``pinchange``: today's path, the PCINT0 vector reads TCNT1 when it runs.

Both run beside a Timer2 vector of ~300 cycles every 25 us, the competing vector's worst
measured in the firmware (the encoder's INT0/INT1, another port's PCINT).  The host
(``host.c``, libsimavr) drives 50 pulses of 1,000-2,000 us at random phase and compares
each board width with the cycles the pin was high.  Simulated time: no wall clock.

    .venv/bin/python -m benchmarks.rc_capture_probe --json benchmarks/results/rc_capture.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from ._results import command_line, write_result

HERE = Path(__file__).resolve().parent / "rc_capture"
PATHS = ("capture", "pinchange")


def build(directory: Path) -> Path:
    host = directory / "host"
    subprocess.run(
        [
            *("cc", "-O2", "-Wall", "-I/usr/include/simavr", "-o", str(host), str(HERE / "host.c")),
            *("-lsimavr", "-lelf", "-lpthread", "-lm"),
        ],
        check=True,
    )
    for name in PATHS:
        subprocess.run(
            [
                *("avr-gcc", "-mmcu=atmega328p", "-DF_CPU=16000000UL", "-Os", "-o"),
                *(str(directory / f"{name}.elf"), str(HERE / f"{name}.c")),
            ],
            check=True,
        )
    return host


def address(elf: Path, symbol: str) -> str:
    out = subprocess.run(["avr-nm", str(elf)], check=True, capture_output=True, text=True)
    return next(line.split()[0] for line in out.stdout.splitlines() if line.endswith(f" {symbol}"))


def measure(pulses: int) -> dict[str, Any]:
    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        host = build(Path(tmp))
        for name in PATHS:
            elf = Path(tmp) / f"{name}.elf"
            args = [str(elf), address(elf, "widths"), address(elf, "n"), str(pulses)]
            out = subprocess.run([str(host), *args], check=True, capture_output=True, text=True)
            line = next(line for line in out.stdout.splitlines() if line.startswith("{"))
            results[name] = json.loads(line)
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pulses", type=int, default=50, help="at most 64")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    result = {
        "command": command_line(),
        "load": "a Timer2 vector of ~300 cycles every 25 us beside the timed pin",
        "clock": "simulated cycles (libsimavr); no wall clock",
        **measure(args.pulses),
    }
    for name in PATHS:
        r = result[name]
        print(f"{name}: {r['captured']}/{r['pulses']} pulses, max {r['error_us_max']} us")
    if args.json:
        write_result(args.json, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
