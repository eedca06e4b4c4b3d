"""The MPU-6050 model's log of the reads it served: the oracle of every IMU stream test."""

from __future__ import annotations

from typing import Any

from arduinoio_async.sim import VirtualUno


async def served(uno: VirtualUno, first: int) -> list[bytes]:
    """The 14 bytes of each read the model logged, from index ``first`` to the newest."""
    out: list[bytes] = []
    while True:
        reply: dict[str, Any] = await uno.command("imu_reads", **{"from": first + len(out)})
        assert reply["from"] == first + len(out), "the model's log ring overran"
        out += [bytes(data) for _, data in reply["reads"]]
        if first + len(out) >= reply["logged"]:
            return out
