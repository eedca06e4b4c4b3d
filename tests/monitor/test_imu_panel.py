"""The monitor's IMU panel on the virtual Uno: started from the page, its readings are
the harness's MPU-6050 model's motion (z = 1 g at rest, the ranges the page chose)."""

from __future__ import annotations

from typing import Any

import anyio
import pytest

from arduinoio_async.board.imu import STANDARD_GRAVITY
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .test_device_panels import monitored

monitor = pytest.importorskip("arduinoio_async.monitor")
pytestmark = pytest.mark.sim


async def test_an_imu_started_on_the_page_shows_the_models_motion(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory()
    async with monitored(uno) as tab:
        await tab.receive("board")
        reply = await tab.call("imu", address=0x68, accel_g=4, gyro_dps=500)
        assert reply["ok"], reply
        with anyio.fail_after(10):
            rows: list[dict[str, Any]] = []
            while not rows:
                rows = (await tab.receive("board"))["imu"]["rows"]
        state = await uno.command("imu")
    assert (state["pwr_mgmt_1"], state["accel_config"], state["gyro_config"]) == (1, 8, 8)
    row = rows[0]
    assert row["accel_g"] == 4 and row["gyro_dps"] == 500
    assert abs(row["accel"][2] - STANDARD_GRAVITY) < 0.01
    assert abs(row["gyro"][1] - (-50 * 3.141592653589793 / 180)) < 0.001
