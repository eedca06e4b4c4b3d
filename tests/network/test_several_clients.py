"""Several clients of one served board: joining while another streams, pins held by one
client, the failsafe owner across a server restart (issue 25, items 15-17)."""

from __future__ import annotations

import sys

import anyio
import pytest

from arduinoio_async import A0
from arduinoio_async.network import RemoteBoards, open_remote_board

from .conftest import ServeFactory

pytestmark = pytest.mark.sim

#: A client joining must not need longer than this (it takes well under a second).
JOIN_TIMEOUT = 4.0


@pytest.mark.parametrize("period_ms", [1, 20])
async def test_a_client_joins_while_another_streams(
    serve_unos: ServeFactory, period_ms: int
) -> None:
    """Another client's samples reach every client's session: a joining client's wait
    for the board must not depend on a pause in them (it never comes at 20 ms)."""
    async with serve_unos([7]) as served, RemoteBoards(connect=[served.endpoint]) as first:
        streamer = await first.get(7)
        async with (
            streamer.stream(analog=[A0], period_ms=period_ms) as samples,
            anyio.create_task_group() as tg,
        ):
            received = 0

            async def consume() -> None:
                nonlocal received
                async for _ in samples:
                    received += 1

            tg.start_soon(consume)
            for _ in range(2):
                async with open_remote_board(
                    7, connect=[served.endpoint], ready_timeout=JOIN_TIMEOUT
                ) as joined:
                    assert await joined.read_id() == 7
            # A client in its own process, as `arduinoio status --remote` is.
            command = [sys.executable, "-m", "arduinoio_async", "status", "--remote"]
            command += ["--id", "0x0007", "--connect", served.endpoint]
            result = await anyio.run_process(command, check=False)
            assert result.returncode == 0, result.stderr.decode()
            tg.cancel_scope.cancel()
        # The streaming client lost nothing to the newcomers.
        assert received > 0 and samples.gaps == 0 and samples.dropped == 0
