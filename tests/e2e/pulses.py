"""Waiting for the fixture's pulse capture without guessing how long it takes."""

from __future__ import annotations

import json
import socket
from typing import Any

import anyio

from arduinoio_async.sim import PulseStats, VirtualUno


async def fresh_pulses(uno: VirtualUno, pin: str, count: int, within: float = 2.0) -> PulseStats:
    """Clear ``pin``'s capture and return it once ``count`` whole pulses were recorded."""
    await uno.clear_pulse_stats(pin)
    with anyio.fail_after(within):
        while True:
            stats = await uno.pulse_stats(pin)
            if stats.highs >= count:
                return stats
            await anyio.sleep(0.02)  # one servo period is 20 ms


async def sim_us(uno: VirtualUno) -> float:
    """The virtual Uno's simulated time now (us)."""
    return float((await uno.status())["sim_us"])


async def steady_level(uno: VirtualUno, pin: str, periods_us: float, within: float = 2.0) -> int:
    """The level ``pin`` holds without a single edge for ``periods_us`` of simulated time
    (duty 0 % or 100 %: no pulse at all, not a short one); fails if it keeps changing."""
    with anyio.fail_after(within):
        while True:
            await uno.clear_pulse_stats(pin)
            start = await sim_us(uno)
            while await sim_us(uno) < start + periods_us:  # noqa: ASYNC110 - simulated clock
                await anyio.sleep(0.005)
            stats = await uno.pulse_stats(pin)
            if stats.count == 0 and stats.falls == 0:
                return stats.level


def control_now(uno: VirtualUno, cmd: str, **params: object) -> dict[str, Any]:
    """One control command sent without an event loop: for a test that blocks its loop on
    purpose, or a plain-thread (blocking API) test."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.settimeout(5)
        sock.connect(uno.control_path)
        sock.sendall(json.dumps({"cmd": cmd, **params}).encode() + b"\n")
        reply = b""
        while not reply.endswith(b"\n"):
            reply += sock.recv(65536)
    answer: dict[str, Any] = json.loads(reply)
    assert answer.get("ok"), answer
    return answer
