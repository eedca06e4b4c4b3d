"""What ``arduinoio serve``'s manager does with ports and boards it cannot use: a port
another process holds is tried again once free, and each reason a port is skipped is
logged once."""

from __future__ import annotations

import json
import logging
import os
import socket
import sys
from pathlib import Path

import anyio
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async import protocol as p
from arduinoio_async.board.failsafe import IDLE_HEARTBEAT
from arduinoio_async.errors import BoardNotFoundError
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import free_endpoint

pytestmark = pytest.mark.sim

HOLDER = """
import sys, serial
port = serial.Serial(sys.argv[1], exclusive=True)
print("held", flush=True)
sys.stdin.read()
"""


async def test_a_port_busy_at_start_is_tried_again_once_free(
    virtual_uno_factory: VirtualUnoFactory, caplog: pytest.LogCaptureFixture
) -> None:
    uno = await virtual_uno_factory(board_id=5)
    holder = await anyio.open_process([sys.executable, "-c", HOLDER, uno.port])
    async with holder:
        assert holder.stdout is not None and holder.stdin is not None
        with anyio.fail_after(10):
            assert (await holder.stdout.receive()).strip() == b"held"
        caplog.set_level(logging.INFO, logger="arduinoio_async.manager")
        async with BoardManager(
            ports=[uno.port], usb=False, env=False, rescan_interval=0.1
        ) as boards:
            with pytest.raises(BoardNotFoundError) as missing:
                await boards.get(5, timeout=0.6)  # several scans meet the busy port
            assert "in use" in missing.value.tried[uno.port]
            await holder.stdin.aclose()  # the other process lets the port go
            await holder.wait()
            board = await boards.get(5, timeout=5)
            assert await board.read_id() == 5
    skipped = [r.getMessage() for r in caplog.records if uno.port in r.getMessage()]
    busy = [message for message in skipped if "in use" in message]
    assert len(busy) == 1, skipped  # said once, not at every scan


async def test_a_trip_nobody_here_armed_is_reported_once(
    virtual_uno_factory: VirtualUnoFactory, caplog: pytest.LogCaptureFixture
) -> None:
    """A failsafe armed by someone else (a served client that died) trips: the manager
    has nothing to re-arm, so it says so once, not at every heartbeat."""
    uno = await virtual_uno_factory(board_id=5)
    caplog.set_level(logging.INFO, logger="arduinoio_async")
    events: list[ManagerEvent] = []
    async with BoardManager(ports=[uno.port], usb=False, env=False, rescan_interval=None) as boards:
        boards.subscribe(events.append)
        board = await boards.get(5)
        tripped = anyio.Event()
        board.on_failsafe(lambda _: tripped.set())
        await board.request(p.FailsafeArm(50))  # not through board.arm_failsafe: not ours
        with anyio.fail_after(5):
            await tripped.wait()
        heartbeats = 6 * IDLE_HEARTBEAT * 1e6  # of the board's time
        start = float((await uno.status())["sim_us"])
        with anyio.fail_after(10):
            while float((await uno.status())["sim_us"]) < start + heartbeats:
                await uno.pin("D2")  # the harness's control line: the link stays idle
        assert board.failsafe_tripped
    assert [e for e in events if e.kind == "failsafe"] == []
    said = [r.getMessage() for r in caplog.records if "failsafe" in r.getMessage()]
    assert len(said) == 1, said


async def test_serve_prints_where_its_config_file_makes_it_listen(tmp_path: Path) -> None:
    endpoint = free_endpoint()
    config = tmp_path / "zenoh.json5"
    config.write_text(
        json.dumps(
            {
                "mode": "peer",
                "listen": {"endpoints": [endpoint]},
                "scouting": {"multicast": {"enabled": False}},
            }
        )
    )
    command = [sys.executable, "-m", "arduinoio_async", "serve", "--no-usb", "-v"]
    command += ["--config", str(config)]
    env = {k: v for k, v in os.environ.items() if k != "ARDUINOIO_PORTS"}
    async with await anyio.open_process(command, env=env) as server:
        try:
            assert server.stdout is not None
            with anyio.fail_after(20):
                line = await BufferedByteReceiveStream(server.stdout).receive_until(b"\n", 4096)
            assert json.loads(line) == {"serving": [], "listen": [endpoint]}
            with socket.create_connection(("127.0.0.1", int(endpoint.rsplit(":", 1)[1]))):
                pass  # it does listen there
        finally:
            server.terminate()
            with anyio.move_on_after(5):
                await server.wait()
            if server.returncode is None:
                server.kill()
