"""A board unplugged and plugged back while the monitor runs: the same panel carries on."""

from __future__ import annotations

from typing import Any

import anyio
import pytest

from arduinoio_async import D3
from arduinoio_async.manager import BoardManager
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

monitor = pytest.importorskip("arduinoio_async.monitor")

pytestmark = pytest.mark.sim


async def next_message(subscriber: Any, kind: str) -> dict[str, Any]:
    with anyio.fail_after(10):
        while True:
            message: dict[str, Any] = await subscriber.messages.receive()
            if message["type"] == kind:
                return message


async def test_the_stream_comes_back_after_unplug_and_replug(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=9)
    await uno.set_analog(2, 1000)
    async with BoardManager(ports=[uno.port], rescan_interval=0.05) as boards:
        board = await boards.get(9)
        hub = monitor.MonitorHub([board], period_ms=10)
        page = hub.subscribe()
        async with anyio.create_task_group() as tg:
            tg.start_soon(hub.run)
            while not (await next_message(page, "samples"))["analog"].get("A2"):
                pass
            await uno.unplug()
            while (await next_message(page, "board"))["stream"]["running"]:
                pass
            await uno.set_analog(2, 4000)
            new_port = await uno.replug()
            boards.add_port(new_port)
            expected = round(4000 * 1024 / 5000)
            while not any(
                abs(value - expected) <= 3
                for value in (await next_message(page, "samples"))["analog"].get("A2", [])
            ):
                pass
            snapshot = hub.panels["b0"].snapshot()
            assert snapshot["connected"] and snapshot["port"] == new_port
            assert snapshot["stream"]["running"]
            tg.cancel_scope.cancel()


async def test_change_events_come_back_after_a_reset_and_a_replug(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The board forgets its subscriptions in a reset (here one the manager notices, not
    the page) and a replug: the monitor subscribes D3 again, and its edges count on."""
    uno = await virtual_uno_factory(board_id=10)
    async with BoardManager(ports=[uno.port], rescan_interval=0.05) as boards:
        board = await boards.get(10)
        hub = monitor.MonitorHub([board], stream=False)
        panel = hub.panels["b0"]
        page = hub.subscribe()
        async with anyio.create_task_group() as tg:
            tg.start_soon(hub.run)
            await board.digital_input(D3)

            async def rises_after(edges: int) -> None:
                """Drive one more rise of D3 until the page counts ``edges`` rises."""
                await uno.drive("D3", 1)
                while (await next_message(page, "samples"))["rises"][3 - 2] < edges:
                    pass
                await uno.drive("D3", 0)

            subscriptions = panel.changes.state.subscriptions
            while panel.changes.state.subscriptions == subscriptions:
                await next_message(page, "board")
            await rises_after(1)

            subscriptions = panel.changes.state.subscriptions
            await uno.reset()  # behind the monitor's back: the manager restores D3
            while panel.changes.state.subscriptions == subscriptions:
                await next_message(page, "board")
            await rises_after(2)

            subscriptions = panel.changes.state.subscriptions
            await uno.unplug()
            boards.add_port(await uno.replug())
            while panel.changes.state.subscriptions == subscriptions:
                await next_message(page, "board")
            await rises_after(3)
            assert panel.changes.lost == 0
            tg.cancel_scope.cancel()
