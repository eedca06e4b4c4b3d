"""pyserial URL forms plug into the same transport: ``socket://`` to a board on TCP."""

from __future__ import annotations

import os

import anyio
import anyio.abc
import pytest

from arduinoio_async import D2
from arduinoio_async.board import Board
from arduinoio_async.errors import PortBusyError
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
