"""pyserial URL forms plug into the same transport: ``socket://`` to a board on TCP."""

from __future__ import annotations

import os
import termios

import anyio
import anyio.abc
import pytest
import serial

from arduinoio_async import D2
from arduinoio_async.board import Board
from arduinoio_async.errors import BoardDisconnectedError, PortBusyError
from arduinoio_async.manager import BoardManager
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport._serial import open_serial_stream


async def test_a_board_behind_socket_url() -> None:
    async with FakeBoard(board_id=0x0A0B) as fake, anyio.create_task_group() as tg:
        listener = await anyio.create_tcp_listener(local_host="127.0.0.1")
        port = listener.extra(anyio.abc.SocketAttribute.local_port)

        async def bridge(client: anyio.abc.SocketStream) -> None:
            async def upstream() -> None:
                async for chunk in client:
                    await fake.host_stream.send(chunk)

            async def downstream() -> None:
                while True:
                    await client.send(await fake.host_stream.receive())

            async with anyio.create_task_group() as inner:
                inner.start_soon(upstream)
                inner.start_soon(downstream)

        tg.start_soon(listener.serve, bridge)
        async with Board.open(f"socket://127.0.0.1:{port}", timeout=1.0) as board:
            assert board.board_id == 0x0A0B
            await board.gpio(D2).write(True)
            assert fake.levels[2] is True
        tg.cancel_scope.cancel()


async def test_a_port_held_by_another_program_is_refused_not_shared() -> None:
    """Two programs on one port would steal each other's replies: the second is refused."""
    master, slave = os.openpty()
    path = os.ttyname(slave)
    try:
        first = await open_serial_stream(path)
        try:
            with pytest.raises(PortBusyError) as caught:
                await open_serial_stream(path)
            assert caught.value.port == path
        finally:
            await first.aclose()
        second = await open_serial_stream(path)  # free again once the first one closed
        await second.aclose()
    finally:
        os.close(master)
        os.close(slave)


class _VanishingPort:
    """A port that disappears between open() and its termios set-up, as a pty or USB
    device unplugged at that moment does: pyserial then raises ``termios.error`` (EIO),
    which is not an ``OSError``."""

    def open(self) -> None:
        raise termios.error(5, "Input/output error")


async def test_a_port_that_vanishes_while_opening_is_a_disconnect(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(serial, "serial_for_url", lambda *args, **kwargs: _VanishingPort())
    with pytest.raises(BoardDisconnectedError, match="Input/output error"):
        await open_serial_stream("/dev/ttyACM9")


async def test_the_manager_outlives_a_port_that_vanishes_while_opening(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """It crashed the manager's rescan with a raw termios.error before (a replug test)."""
    monkeypatch.setattr(serial, "serial_for_url", lambda *args, **kwargs: _VanishingPort())
    async with BoardManager(ports=["/dev/ttyACM9"], rescan_interval=None) as boards:
        assert "Input/output error" in boards.probed()["/dev/ttyACM9"].error
        assert not boards.present()
