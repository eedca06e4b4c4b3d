"""A watch of a board served on the network survives the board's reset (the same restore
path as a local board: the client's supervisor adopts the fresh boot, roles then watches)."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D3
from arduinoio_async.network import RemoteBoards

from ..fake_boards import reset_event
from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_change_watch_keeps_delivering_after_the_board_resets(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7]) as served,
        RemoteBoards(connect=[served.endpoint]) as remote,
    ):
        uno = served.unos[7]
        board = await remote.get(7)
        reset_seen = reset_event(remote)
        async with board.gpio(D3).watch() as changes:
            with anyio.fail_after(5):  # each level once the board saw the one before
                await uno.drive("D3", 1)
                before = [await anext(changes)]
                await uno.drive("D3", 0)
                before.append(await anext(changes))
            await uno.reset()
            with anyio.fail_after(10):
                await reset_seen.wait()
                assert await remote.wait_connected(7) is board
            await uno.drive("D3", 1)
            with anyio.fail_after(5):
                after = await anext(changes)
        assert [(c.level, c.sequence) for c in before] == [(True, 0), (False, 1)]
        assert (after.level, after.sequence) == (True, 0)  # a fresh boot numbers from 0
        assert changes.restarts == 1 and changes.lost == 0
