"""The monitor server without a browser: who may connect, and the controls' answers.

A FakeBoard stands in for the Uno (its model follows the firmware), and a plain WebSocket
client speaks the page's JSON messages over loopback.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest

from arduinoio_async import UsageError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard

monitor = pytest.importorskip("arduinoio_async.monitor")
ws_client = pytest.importorskip("websockets.asyncio.client")
ws_errors = pytest.importorskip("websockets.exceptions")

from arduinoio_async.monitor import _hub  # noqa: E402  (after the extra's import check)


@asynccontextmanager
async def fake_monitor(token: str | None = None) -> AsyncIterator[tuple[FakeBoard, Any]]:
    async with (
        FakeBoard(board_id=0x0042) as fake,
        Board.connect(fake.host_stream) as board,
        monitor.serve_monitor([board], http="127.0.0.1:0", token=token, period_ms=10) as server,
    ):
        yield fake, server


async def http_get(port: int, target: str, host: str = "127.0.0.1") -> int:
    """Status code of a plain HTTP GET over loopback."""
    async with await anyio.connect_tcp("127.0.0.1", port) as stream:
        await stream.send(
            f"GET {target} HTTP/1.1\r\nHost: {host}:{port}\r\nConnection: close\r\n\r\n".encode()
        )
        head = b""
        while b"\r\n" not in head:
            head += await stream.receive()
    return int(head.split()[1])


class Page:
    """The page's side of the WebSocket: requests by id, messages by type."""

    def __init__(self, connection: Any) -> None:
        self.connection = connection
        self.next_id = 0
        self.board = "b0"

    async def receive(self, kind: str) -> dict[str, Any]:
        with anyio.fail_after(5):
            while True:
                message: dict[str, Any] = json.loads(await self.connection.recv())
                if message["type"] == kind:
                    return message

    async def call(self, op: str, **args: Any) -> dict[str, Any]:
        self.next_id += 1
        await self.connection.send(
            json.dumps({"id": self.next_id, "board": self.board, "op": op, **args})
        )
        with anyio.fail_after(5):
            while True:
                message = await self.receive("result")
                if message["id"] == self.next_id:
                    return message


@asynccontextmanager
async def page(url: str, **options: Any) -> AsyncIterator[Page]:
    async with ws_client.connect(url, proxy=None, **options) as connection:
        yield Page(connection)


def ws_url(server: Any, token: str | None = None) -> str:
    return f"ws://127.0.0.1:{server.port}/ws" + (f"?token={token}" if token else "")


async def test_non_loopback_address_needs_a_token() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        with pytest.raises(UsageError, match="needs a token"):
            async with monitor.serve_monitor([board], http="0.0.0.0:0"):
                pass
        with pytest.raises(UsageError, match="HOST:PORT"):
            async with monitor.serve_monitor([board], http="localhost"):
                pass


async def test_token_host_and_origin_are_checked() -> None:
    async with fake_monitor(token="s3cret") as (_fake, server):
        assert server.url.endswith("/?token=s3cret")
        assert await http_get(server.port, "/") == 403
        assert await http_get(server.port, "/?token=wrong") == 403
        assert await http_get(server.port, "/?token=s3cret") == 200
        assert await http_get(server.port, "/?token=s3cret", host="attacker.example") == 400
        assert await http_get(server.port, "/static/vendor/uPlot.iife.min.js") == 200
        for url, options in [
            (ws_url(server), {}),
            (ws_url(server, "wrong"), {}),
            (ws_url(server, "s3cret"), {"origin": "http://attacker.example"}),
        ]:
            with pytest.raises(ws_errors.InvalidStatus):
                async with page(url, **options):
                    pass
        origin = f"http://127.0.0.1:{server.port}"
        async with page(ws_url(server, "s3cret"), origin=origin) as tab:
            snapshot = await tab.receive("board")
            assert snapshot["id"] == 0x42
            assert [pin["name"] for pin in snapshot["pins"]][:2] == ["D2", "D3"]


async def test_controls_reach_the_board_and_refusals_come_back() -> None:
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        assert (await tab.call("role", pin="D2", role="output"))["ok"]
        assert (await tab.call("write", pin="D2", value=1))["ok"]
        assert fake.role(2) == "output" and fake.levels[2]
        while not (await tab.receive("samples"))["levels"] & 1 << 2:
            pass  # the stream shows the level the board drives

        fake.drive(5, True)
        assert (await tab.call("role", pin="D5", role="input"))["ok"]
        fake.drive(5, False)
        while (await tab.receive("samples"))["falls"][5 - 2] < 1:
            pass

        assert (await tab.call("role", pin="D9", role="servo"))["ok"]
        assert (await tab.call("pulse", pin="D9", us=1500))["ok"]
        assert fake.pulses[9] == 1500
        snapshot = await tab.receive("board")
        while snapshot["pins"][9 - 2]["value"] != 1500:
            snapshot = await tab.receive("board")

        refusals = {
            ("role", "D1"): "not a digital pin",
            ("role", "D2x"): "not a digital pin",
            ("pulse", "D2"): "D2 is in use as output",
            ("write", "D9"): "D9 is in use as servo",
        }
        for (op, pin), reason in refusals.items():
            reply = await tab.call(op, pin=pin, role="servo", value=1, us=1500)
            assert not reply["ok"] and reason in reply["error"], reply
        reply = await tab.call("role", pin="D2", role="servo")
        assert not reply["ok"] and "D2 cannot be servo" in reply["error"]
        reply = await tab.call("pulse", pin="D9", us=2500)
        assert not reply["ok"] and "1000-2000" in reply["error"]
        assert fake.pulses[9] == 1500
        reply = await tab.call("role", pin="D10", role="duty")  # D9 is a servo: Timer1 is
        assert not reply["ok"] and "D9 is servo PWM" in reply["error"]  # refused unsent
        assert fake.role(10) == "free"
        assert (await tab.call("role", pin="D3", role="duty"))["ok"]  # the duty slider
        assert (await tab.call("duty", pin="D3", permille=370))["ok"]
        assert fake.duties[3] == (10000, round(0.37 * p.DUTY_FULL))
        snapshot = await tab.receive("board")
        while snapshot["pins"][3 - 2]["value"] != 370:
            snapshot = await tab.receive("board")
        reply = await tab.call("fly")
        assert not reply["ok"] and "unknown monitor operation" in reply["error"]
        reply = await tab.call("i2c_write", address=0x50, register=0, data="zz")
        assert not reply["ok"] and "hex bytes" in reply["error"]


async def test_reset_restores_roles_and_restarts_the_stream() -> None:
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        assert (await tab.call("role", pin="D4", role="output"))["ok"]
        assert (await tab.call("write", pin="D4", value=1))["ok"]
        assert (await tab.call("failsafe_arm", timeout_ms=500))["ok"]
        assert (await tab.call("reset"))["ok"]
        assert fake.role(4) == "output" and fake.levels[4]
        assert fake.failsafe.armed
        received = (await tab.receive("samples"))["stream"]["received"]
        while not (stream := (await tab.receive("samples"))["stream"])["running"] or (
            stream["received"] <= received
        ):
            received = stream["received"]
        assert (await tab.call("failsafe_disarm"))["ok"]
        reply = await tab.call("failsafe_rearm")
        assert not reply["ok"] and "not armed" in reply["error"]


async def test_a_page_that_stops_reading_is_dropped_not_waited_for() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        hub = monitor.MonitorHub([board])
        stuck = hub.subscribe()
        reading = hub.subscribe()
        for index in range(_hub.SUBSCRIBER_QUEUE + 1):
            hub.broadcast({"type": "test", "n": index})
            if index % 64 == 0:
                while reading.messages.statistics().current_buffer_used:
                    reading.messages.receive_nowait()
        assert stuck not in hub._subscribers and reading in hub._subscribers
        drained = [message async for message in stuck.messages]
        # The snapshot and what fitted, in order, then the end of the stream.
        assert len(drained) == _hub.SUBSCRIBER_QUEUE
        assert [m["n"] for m in drained[1:]] == list(range(_hub.SUBSCRIBER_QUEUE - 1))


async def test_a_tripped_failsafe_shows_and_rearms_with_outputs_restored() -> None:
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        assert (await tab.call("role", pin="D6", role="output"))["ok"]
        assert (await tab.call("write", pin="D6", value=1))["ok"]
        assert (await tab.call("failsafe_arm", timeout_ms=200))["ok"]
        await fake.expire_failsafe()
        while (await tab.receive("board"))["failsafe"] != "tripped":
            pass
        assert not fake.levels[6]  # the board applied the safe state
        reply = await tab.call("write", pin="D6", value=1)
        assert not reply["ok"] and "failsafe" in reply["error"].lower()
        assert (await tab.call("failsafe_rearm"))["ok"]
        assert fake.levels[6] and fake.failsafe.armed
        snapshot = await tab.receive("board")
        while snapshot["failsafe"] != "armed (200 ms)":
            snapshot = await tab.receive("board")


async def test_every_board_gets_its_own_panel() -> None:
    async with (
        FakeBoard(board_id=0x0001) as left_fake,
        FakeBoard(board_id=0x0002) as right_fake,
        Board.connect(left_fake.host_stream) as left,
        Board.connect(right_fake.host_stream) as right,
        monitor.serve_monitor([left, right], http="127.0.0.1:0") as server,
        page(ws_url(server)) as tab,
    ):
        first, second = await tab.receive("board"), await tab.receive("board")
        assert {(first["key"], first["id"]), (second["key"], second["id"])} == {
            ("b0", 1),
            ("b1", 2),
        }
        tab.board = "b1"
        assert (await tab.call("role", pin="D7", role="output"))["ok"]
        assert right_fake.role(7) == "output" and left_fake.role(7) == "free"
