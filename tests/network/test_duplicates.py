"""Two ``arduinoio serve`` processes announcing one board ID (loopback only)."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async.errors import DuplicateBoardError
from arduinoio_async.network import NetworkBoardManager, RemoteBoards

from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_two_servers_with_one_id_are_duplicates_until_one_goes(
    serve_unos: ServeFactory,
) -> None:
    async with serve_unos([7]) as first:
        second_server = serve_unos([7])
        second = await second_server.__aenter__()
        second_open = True
        try:
            endpoints = [first.endpoint, second.endpoint]
            async with RemoteBoards(connect=endpoints) as remote:
                with anyio.fail_after(10):
                    servers = await remote.wait_announced(7, servers=2)
                with pytest.raises(DuplicateBoardError) as caught:
                    await remote.get(7)
                assert caught.value.board_id == 7
                assert caught.value.ports == tuple(sorted(f"zenoh server {s}" for s in servers))
                # A waiter that started earlier is told too, not left waiting.
                with pytest.raises(DuplicateBoardError):
                    await remote.wait_connected(7)
                # The manager reports it the same way, before trying any port.
                async with NetworkBoardManager(
                    ports=[], usb=False, env=False, connect=endpoints
                ) as boards:
                    assert boards.remote is not None
                    with anyio.fail_after(10):
                        await boards.remote.wait_announced(7, servers=2)
                    with pytest.raises(DuplicateBoardError):
                        await boards.get(7)

                # One server goes: its token vanishes and the ID names one board again.
                second_open = False
                await second_server.__aexit__(None, None, None)
                with anyio.fail_after(10):
                    left = await remote.wait_announced(7, servers=1)
                assert left < servers
                board = await remote.get(7, timeout=10)
                assert await board.read_id() == 7
        finally:
            if second_open:
                await second_server.__aexit__(None, None, None)
