"""Waiting for the fixture's pulse capture without guessing how long it takes."""

from __future__ import annotations

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
