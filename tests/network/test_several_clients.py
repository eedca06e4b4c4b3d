"""Several clients of one served board: joining while another streams, pins held by one
client, the failsafe owner across a server restart (issue 25, items 15-17)."""

from __future__ import annotations

import sys

import anyio
import pytest

from arduinoio_async import A0, D6, D7
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError
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


async def test_a_client_cannot_take_another_clients_pin(serve_unos: ServeFactory) -> None:
    """Within one client a second role on a pin is a PinRoleError; between clients the
    server refuses it with the board's PIN_BUSY, and the holder's output keeps working."""
    async with (
        serve_unos([7], fixture="loopback") as served,
        RemoteBoards(connect=[served.endpoint]) as first,
        RemoteBoards(connect=[served.endpoint]) as second,
    ):
        uno = served.unos[7]
        a, b = await first.get(7), await second.get(7)
        led = await a.digital_output(D6, initial=True)
        with pytest.raises(BoardError) as busy:
            await b.digital_input(D6)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # nor release it from under A
            await b.release(D6)
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with pytest.raises(BoardError) as busy:  # nor inside a transaction
            async with b.transaction() as tx:
                tx.add(p.GpioConfig(int(D6), p.GpioFlags(0)))
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        assert D6 not in b.roles  # B's refused claim was undone
        await led.write(False)  # A's output is still A's
        assert (await uno.pin("D6")).level == 0
        await led.write(True)
        assert (await uno.pin("D6")).level == 1
        # The same role is shared (a restarted controller sets its pins up again) ...
        again = await b.digital_output(D6, initial=True)
        await again.write(True)
        # ... and a pin nobody else holds is free to change.
        await b.digital_input(D7)
        inp = b.roles[D7]
        assert inp.role == "digital input"
        await b.release(D7)
        await a.digital_output(D7)
