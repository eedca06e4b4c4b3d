"""A resync after two lost frames must not leave the board unfed for a whole failsafe.

At 1e-3 line faults an idle, healthy host tripped a 100 ms failsafe about twice an hour
(benchmarks/idle_failsafe.py).  The mechanism, reproduced here with the faults placed on
purpose: a keepalive poll is corrupted on its way to the board (the board answers an
error, the host loses sync), and the first ID probe of the resync is lost on its way too.
The board last heard a valid frame one heartbeat before the corrupted poll; the host then
drained for 30 ms, waited 25 ms for the lost probe's answer and backed off another 30 ms
before probing again: ~110 ms without a frame reaching the board.  The oracle is the
fixture's: the armed output (D4, safe level low) must never fall.
"""

from __future__ import annotations

import anyio
import anyio.abc
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import open_serial_stream

from .test_failsafe import arm

pytestmark = pytest.mark.sim


class RequestSpoiler(anyio.abc.ByteStream):
    """Spoils the host's next frame that starts with a given request: ``corrupt`` flips
    its check byte (the board sees a bad frame), ``lose`` keeps it off the line."""

    def __init__(self, inner: anyio.abc.ByteStream) -> None:
        self.inner = inner
        self._plan: list[tuple[bytes, str]] = []
        self.done = anyio.Event()

    def spoil(self, *plan: tuple[bytes, str]) -> None:
        self._plan = list(plan)
        self.done = anyio.Event()

    async def receive(self, max_bytes: int = 65536) -> bytes:
        return await self.inner.receive(max_bytes)

    async def send(self, item: bytes) -> None:
        if self._plan and item.startswith(self._plan[0][0]):
            _, how = self._plan.pop(0)
            if not self._plan:
                self.done.set()
            if how == "lose":
                return
            item = item[:-1] + bytes([item[-1] ^ 0x5A])
        await self.inner.send(item)

    async def send_eof(self) -> None:
        await self.inner.send_eof()

    async def aclose(self) -> None:
        await self.inner.aclose()


async def test_a_spoiled_poll_then_a_lost_probe_never_trips_a_100ms_failsafe(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    stream = RequestSpoiler(await open_serial_stream(uno.port, uno.baud))
    async with Board.connect(stream, name=uno.port) as board:
        await arm(board)
        await uno.clear_pulse_stats("D4")
        resyncs = board.link.stats.resyncs
        poll = p.ReadStatus().encode()[:2]
        probe = p.ReadId().encode()[:2]
        stream.spoil((poll, "corrupt"), (probe, "lose"))
        with anyio.fail_after(10):
            await stream.done.wait()
            while board.link.stats.resyncs == resyncs or board.link.state.name != "READY":  # noqa: ASYNC110
                await anyio.sleep(0.01)
        for _ in range(10):  # a few heartbeats more: the board has been fed again
            await anyio.sleep(board.heartbeat_interval())
        d4 = await uno.pulse_stats("D4")
        assert d4.falls == 0 and d4.level == 1, f"the failsafe tripped on a healthy host: {d4}"
