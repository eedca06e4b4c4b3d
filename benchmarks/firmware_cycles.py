"""Exact firmware cycle counts, no host and no wall clock.

Builds ``benchmarks/firmware_cycles.c`` against libsimavr and runs it on each ELF:

* ``writes``: pipelined GPIO WRITE to D13, 24 requests in flight, the UART input kept
  fed at the ELF's baud rate.  ``cycles_per_command`` is simulated CPU cycles per
  command; when it is above the wire's time per command (simavr moves 11 bit times a
  byte: 880 cycles for the 5-byte request at 1 Mbaud, 440 at 2 Mbaud) the firmware is
  the limit and the figure is its whole work per command (receive and transmit
  interrupts, parsing, execution, reply, its share of the timer tick).
* ``pwm``: soft PWM on D2-D7 at 1500 us, widths of every pulse from the simulated pin
  edges, with the link idle and under the pipelined writes.
* ``--profile``: the pipelined writes again, with the cycles per command spent in each
  function of the ELF (``avr-nm``) and at its hottest addresses (read them beside
  ``avr-objdump -d``): where the firmware's time goes.
* ``seq``: one request at a time, the virtual Uno's ``firmware_cycles`` definition (last
  request byte read from UDR0 to the first reply byte written), median and minimum.

The virtual Uno (``benchmarks/firmware_wire_speed.py``) measures the same through a pty
and pyserial, paced to the wall clock; on a loaded machine that measures the host.

    .venv/bin/python -m benchmarks.firmware_cycles --elf before=/tmp/old-2000000.elf \\
        --elf after=firmware/build/arduinoio-2000000.elf --json benchmarks/results/x.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from ._results import command_line, write_result

HERE = Path(__file__).resolve().parent


def build(directory: Path) -> Path:
    binary = directory / "firmware_cycles"
    subprocess.run(
        [
            "cc",
            "-O2",
            "-Wall",
            "-Wextra",
            "-I/usr/include/simavr",
            "-o",
            str(binary),
            str(HERE / "firmware_cycles.c"),
            "-lsimavr",
            "-lelf",
            "-lpthread",
            "-lm",
        ],
        check=True,
    )
    return binary


def run(binary: Path, *args: str) -> dict[str, Any]:
    out = subprocess.run([str(binary), *args], check=True, capture_output=True, text=True).stdout
    # simavr prints "Loaded ..." lines of its own on stdout; the result is the JSON line.
    line = next(line for line in out.splitlines() if line.startswith("{"))
    return dict(json.loads(line))


def symbols(elf: str) -> list[tuple[int, str]]:
    """The ELF's code symbols as (byte address, name), sorted by address."""
    out = subprocess.run(["avr-nm", "-n", elf], check=True, capture_output=True, text=True).stdout
    found = []
    for line in out.splitlines():
        fields = line.split()
        if len(fields) == 3 and fields[1] in "tT" and int(fields[0], 16) < 0x800000:
            found.append((int(fields[0], 16), fields[2]))
    return found


def profile(binary: Path, elf: str, n: int) -> dict[str, Any]:
    """Cycles per pipelined command by function and at the hottest addresses."""
    result = run(binary, elf, "profile", str(n))
    per_address = [(address, cycles / n) for address, cycles in result.pop("profile")]
    table = symbols(elf)
    by_function: dict[str, float] = {}
    for address, cycles in per_address:
        name = "?"
        for start, symbol in table:
            if start > address:
                break
            name = symbol
        by_function[name] = by_function.get(name, 0.0) + cycles
    hottest = sorted(per_address, key=lambda item: -item[1])[:40]
    ranked = sorted(by_function.items(), key=lambda item: -item[1])
    result["by_function"] = {name: round(cycles, 2) for name, cycles in ranked}
    result["hottest"] = [[f"0x{address:04x}", round(cycles, 2)] for address, cycles in hottest]
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elf", action="append", required=True, help="NAME=PATH, repeatable")
    parser.add_argument("--n", type=int, default=3000, help="pipelined commands per run")
    parser.add_argument("--pwm-us", type=int, default=1500)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--profile", action="store_true", help="only the per-function profile")
    args = parser.parse_args()
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        binary = build(Path(tmp))
        for item in args.elf:
            name, path = item.split("=", 1)
            if args.profile:
                results[name] = profile(binary, path, args.n)
                print(name, json.dumps(results[name], indent=1), flush=True)
                continue
            results[name] = {
                "elf": path,
                "writes": run(binary, path, "writes", str(args.n)),
                "pwm_idle": run(binary, path, "pwm", "0", str(args.pwm_us)),
                "pwm_loaded": run(binary, path, "pwm", str(args.n), str(args.pwm_us)),
                "sequential": run(binary, path, "seq", "300"),
            }
            print(name, json.dumps(results[name]), flush=True)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        write_result(args.json, {"command": command_line(), "results": results})


if __name__ == "__main__":
    main()
