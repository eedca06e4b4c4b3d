"""Low-latency mode (docs/protocol.md 7.6) on a served board behind the 16U2 bridge model.

The remote client turns the mode on with the same call as on a local port; the filler
the firmware pads its replies with ends in the server's decoder, so it must never reach
the remote caller; and the client's Board replays the mode on the fresh boot after a
replug, as its local restore does.  Whether filler flowed is read from the virtual Uno's
bridge counter: a burst that the 16U2 model released because more than 96 bytes waited
(a ``read_id`` reply alone is 5 bytes, held until the 4 ms tick).
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.manager import ManagerEvent
from arduinoio_async.network import RemoteBoards
from arduinoio_async.sim import VirtualUno
from arduinoio_async.transport import TraceRecord
from tests.fake_boards import read_ids_concurrently

from .conftest import ServeFactory

pytestmark = pytest.mark.sim

BAUD = 1_000_000
CALLS = 10


async def bursts_released_full(uno: VirtualUno) -> int:
    """Bursts the 16U2 model sent at once because they were padded past 96 bytes."""
    return int((await uno.status())["bridge_full_releases"])


async def padded_read_ids(board: Board, uno: VirtualUno) -> int:
    """Sequential ``read_id`` calls (all checked); how many bursts left the bridge padded
    (about one a call; keepalive requests of the server and the client may share one)."""
    before = await bursts_released_full(uno)
    for _ in range(CALLS):
        assert await board.read_id() == 7
    return await bursts_released_full(uno) - before


def watch_for_garbage(board: Board, seen: list[TraceRecord]) -> None:
    """Record every received item of the board's current link that is not a frame."""
    board.link.trace = lambda record: (
        seen.append(record)
        if record.direction == "rx" and isinstance(record.item, p.Garbage)
        else None
    )


async def test_low_latency_mode_over_the_network_and_after_a_replug(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7], baud=BAUD, usb_bridge="16u2", fixture="loopback") as served,
        RemoteBoards(connect=[served.endpoint]) as remote,
    ):
        uno = served.unos[7]
        board = await remote.get(7)
        garbage: list[TraceRecord] = []
        watch_for_garbage(board, garbage)
        assert board.capabilities.features & p.Feature.LOW_LATENCY
        assert await padded_read_ids(board, uno) == 0  # off: every reply waits for the tick

        await board.set_low_latency(True)
        assert board.low_latency
        assert await padded_read_ids(board, uno) >= CALLS // 2  # on: replies padded, sent
        assert await read_ids_concurrently(board) == [7] * 80  # pipelined callers
        d2, d3 = await board.digital_output(D2), await board.digital_input(D3)
        for level in (True, False, True):  # the loopback fixture wires D2 to D3
            await d2.write(level)
            assert (await d3.read()).level is level
        # The filler ended in the server's decoder: not a byte of it reached this client.
        stats = board.link.stats
        assert garbage == [] and stats.garbage_bytes == 0 and stats.resyncs == 0
        assert board.link.stream.faults == []  # type: ignore[attr-defined]

        events: list[str] = []
        changed = anyio.Event()

        def record(event: ManagerEvent) -> None:
            nonlocal changed
            events.append(event.kind)
            changed.set()
            changed = anyio.Event()

        remote.subscribe(record)

        async def wait_for(kind: str) -> None:
            with anyio.fail_after(10):
                while kind not in events:
                    await changed.wait()

        served.unlink_port(7)
        await uno.unplug()
        await wait_for("disconnected")
        await uno.replug()  # a fresh boot: the firmware starts with the mode off
        served.link_port(7)
        await wait_for("connected")
        assert remote.present()[7] is board and board.low_latency
        watch_for_garbage(board, garbage)  # the link is a new one
        # Nobody asked again: the client's restore replayed the mode on the fresh boot.
        assert await padded_read_ids(board, uno) >= CALLS // 2
        assert (await d3.read()).level is True  # the roles came back with it
        stats = board.link.stats
        assert garbage == [] and stats.garbage_bytes == 0 and stats.resyncs == 0
