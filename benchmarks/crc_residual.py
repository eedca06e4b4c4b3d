"""Exact counts behind the residual-error derivation of CRC-16 framing (docs/protocol.md 7.7).

For a reply type, every frame the board can send (or a seeded sample of them), every
position and every value of one inserted byte: how often does the candidate the host
decodes (the frame one byte short, the displaced last byte left over) pass the CRC,
have the reply's tags, pass the echo and value checks, and carry a value other than the
one sent?  That is ``P(wrong | one insertion)``, the factor the derivation multiplies by
the fault rate.  The same for an insertion and a drop in one frame (the length is
right again, nothing is left over), sampled.  XOR framing for comparison.

    .venv/bin/python -m benchmarks.crc_residual --json benchmarks/results/crc_residual.json
"""

from __future__ import annotations

import argparse
import json
import random
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from arduinoio_async import protocol as p
from arduinoio_async.protocol._bounds import TEMPERATURE_RAW_RANGE

from ._results import command_line, write_result


def crc_ok(raw: bytes) -> bool:
    return p.crc16(raw) == 0


def xor_ok(raw: bytes) -> bool:
    check = 0
    for byte in raw:
        check ^= byte
    return check == 0


def _echoes(name: str, value: int) -> Callable[[p.Frame], bool]:
    """The check of an echoed field: the candidate must repeat the request's value."""
    return lambda frame: bool(getattr(frame, name) == value)


def _in_range(frame: p.Frame) -> bool:
    """A temperature reading the chip's sensor can report (the client's bound)."""
    return bool(getattr(frame, "raw") in TEMPERATURE_RAW_RANGE)  # noqa: B009


def analog_frames() -> Iterator[tuple[p.Frame, Callable[[p.Frame], bool]]]:
    for channel in range(6):
        for value in range(1024):
            yield p.AnalogReadReply(channel, value), _echoes("channel", channel)


def temperature_frames() -> Iterator[tuple[p.Frame, Callable[[p.Frame], bool]]]:
    low, high = TEMPERATURE_RAW_RANGE.start, TEMPERATURE_RAW_RANGE.stop - 1
    for raw in range(low, high + 1):
        yield p.ReadTemperatureReply(raw), _in_range


def counter_frames(
    rnd: random.Random, n: int
) -> Iterator[tuple[p.Frame, Callable[[p.Frame], bool]]]:
    for _ in range(n):
        yield p.CounterReadReply(2, rnd.randrange(1 << 32)), _echoes("pin", 2)


def wrong(
    raw: bytes, sent: p.Frame, ok: Callable[[bytes], bool], check: Callable[[p.Frame], bool]
) -> bool:
    """Would the host deliver this candidate as a different answer to the same request?"""
    if not ok(raw) or raw[:2] != sent.encode()[:2]:
        return False
    try:
        frame = type(sent).LAYOUT.decode(raw)
    except ValueError:
        return False  # a value its type forbids: noise
    return frame != sent and check(frame)


def insertion(frames: Any, crc: bool) -> dict[str, Any]:
    ok = crc_ok if crc else xor_ok
    cases = passed = 0
    for sent, check in frames:
        raw = p.crc_framed(sent.encode()) if crc else sent.encode()
        size = len(raw)
        for k in range(1, size):  # before the first byte: a stray byte before the frame
            for x in range(256):
                cases += 1
                passed += wrong((raw[:k] + bytes((x,)) + raw[k:])[:size], sent, ok, check)
    return {"cases": cases, "wrong": passed, "p_wrong_per_insertion": passed / cases}


def insertion_and_drop(frames: Any, crc: bool) -> dict[str, Any]:
    ok = crc_ok if crc else xor_ok
    cases = passed = 0
    for sent, check in frames:
        raw = p.crc_framed(sent.encode()) if crc else sent.encode()
        size = len(raw)
        for k in range(1, size + 1):
            for d in range(size + 1):
                if d == k:
                    continue
                for x in range(256):
                    damaged = raw[:k] + bytes((x,)) + raw[k:]
                    damaged = damaged[:d] + damaged[d + 1 :]
                    cases += 1
                    passed += wrong(damaged[:size], sent, ok, check)
    return {"cases": cases, "wrong": passed, "p_wrong_per_pair": passed / cases}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=200, help="frames sampled for pairs")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    rnd = random.Random(args.seed)
    result: dict[str, Any] = {"command": command_line()}
    for name, make in (
        ("AnalogReadReply", analog_frames),
        ("ReadTemperatureReply", temperature_frames),
        ("CounterReadReply", lambda: counter_frames(random.Random(args.seed), 2000)),
    ):
        every = list(make())
        sample = rnd.sample(every, min(args.sample, len(every)))
        result[name] = {
            "frames": len(every),
            "crc16_insertion": insertion(every, crc=True),
            "xor_insertion": insertion(every, crc=False),
            "crc16_insertion_and_drop": insertion_and_drop(sample, crc=True),
            "frames_sampled_for_pairs": len(sample),
        }
        print(name, json.dumps(result[name]), flush=True)
    if args.json:
        write_result(args.json, result, indent=2)


if __name__ == "__main__":
    main()
