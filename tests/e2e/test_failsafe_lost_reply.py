"""One lost reply must not trip the failsafe of a healthy host.

The keepalive's status poll used to wait out its whole timeout (0.5 s) when its reply was
lost, and the host sent nothing meanwhile: a 100 ms failsafe fired although the host was
alive.  The oracle is the fixture's: the armed output (D4, safe level low) must never
fall while the host is healthy, and must fall within timeout + 20 ms of the host's last
byte once the host really stops.
"""

from __future__ import annotations

import time

import anyio
import anyio.abc
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import open_serial_stream

from .test_failsafe import TIMEOUT_MS, arm

pytestmark = pytest.mark.sim

#: How long a reaction to a stopped host may take beyond the failsafe timeout.
REACTION_SLACK_MS = 20


class ReplyDropper(anyio.abc.ByteStream):
    """A byte stream that loses the next ``count`` bytes from the board when told to:
    one whole reply vanishes on the line, nothing else changes."""

    def __init__(self, inner: anyio.abc.ByteStream) -> None:
        self.inner = inner
        self._to_drop = 0
        self.dropped = anyio.Event()
        #: Bytes received from the board since the drop was complete.
        self.after_drop = 0
        #: The host's bytes no longer reach the board (a host that stopped for good).
        self.muted = False
        self._trigger: tuple[bytes, int] | None = None
        self._to_keep = 0
        self._injected = b""

    def drop_next(self, count: int) -> None:
        self._to_drop = count
        self.dropped = anyio.Event()
        self.after_drop = 0

    def drop_answer_to(self, request: bytes, count: int) -> None:
        """Drop the last ``count`` bytes of the (5-byte) answer to the next ``request`` the
        host sends: the decoder keeps the rest, waiting for a frame that never ends."""
        self._trigger = (request, count)
        self.dropped = anyio.Event()
        self.after_drop = 0

    def inject(self, frame: bytes) -> None:
        """Deliver ``frame`` before the next bytes from the board (a frame nobody asked for)."""
        self._injected = frame

    async def receive(self, max_bytes: int = 65536) -> bytes:
        while True:
            chunk = await self.inner.receive(max_bytes)
            data, self._injected = self._injected + chunk, b""
            if self._to_drop:
                keep = min(self._to_keep, len(data))
                self._to_keep -= keep
                cut = min(self._to_drop, len(data) - keep)
                self._to_drop -= cut
                data = data[:keep] + data[keep + cut :]
                if not self._to_drop:
                    self.dropped.set()
            elif self.dropped.is_set():
                self.after_drop += len(data)
            if data:
                return data

    async def send(self, item: bytes) -> None:
        if self._trigger is not None and self._trigger[0] in item:
            count, self._trigger = self._trigger[1], None
            self._to_keep, self._to_drop = p.ReadIdReply.LAYOUT.base_size - count, count
        if not self.muted:
            await self.inner.send(item)

    async def send_eof(self) -> None:
        await self.inner.send_eof()

    async def aclose(self) -> None:
        await self.inner.aclose()


async def reaction_ms(uno: VirtualUno) -> float:
    """The fixture's view of a stopped host: ms from its last byte to D4's safe edge."""
    with anyio.fail_after(2):
        while (await uno.pin("D4")).level != 0:  # noqa: ASYNC110 - state of another process
            await anyio.sleep(0.01)
    silent_from = float((await uno.status())["last_host_byte_us"])
    edge = (await uno.pulse_stats("D4")).last_edge_us
    assert edge is not None and edge > silent_from
    return (edge - silent_from) / 1000


async def test_one_lost_reply_never_trips_a_100ms_failsafe(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    stream = ReplyDropper(await open_serial_stream(uno.port, uno.baud))
    async with Board.connect(stream, name=uno.port) as board:
        await arm(board)
        assert board.heartbeat_interval() <= TIMEOUT_MS / 1000 / 2
        await uno.clear_pulse_stats("D4")
        # The host is idle: the next bytes from the board are a keepalive poll's reply.
        stream.drop_next(p.ReadStatusReply.LAYOUT.base_size)
        # Watch for longer than the old stall (the poll's timeout, then the resync's drain)
        # measured in the board's replies: the host keeps polling all along.
        replies_to_see = int((board.link.timeout + 0.25) / board.heartbeat_interval())
        with anyio.fail_after(10):
            await stream.dropped.wait()
            while stream.after_drop < replies_to_see * p.ReadStatusReply.LAYOUT.base_size:  # noqa: ASYNC110
                await anyio.sleep(0.05)
        d4 = await uno.pulse_stats("D4")
        assert d4.falls == 0 and d4.level == 1, f"the failsafe tripped on a healthy host: {d4}"

        # The host really stops (its event loop blocks, then it never speaks again): the
        # board still reacts in time.
        time.sleep(0.3)  # noqa: ASYNC251 - the host's event loop is stuck: no heartbeat
        stream.muted = True  # before any task runs: the last byte stays the last
        reaction = await reaction_ms(uno)
        print(f"\nfailsafe reaction after the host stopped: {reaction:.2f} ms")
        assert reaction <= TIMEOUT_MS + REACTION_SLACK_MS


async def test_a_resync_whose_probe_answer_is_lost_never_trips_a_100ms_failsafe(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The link loses sync (a reply that answers nothing arrives) and the answer to its ID
    probe loses a byte: the probe used to wait for the rest for the whole link timeout,
    with the host silent."""
    uno = await virtual_uno_factory(board_id=1)
    stream = ReplyDropper(await open_serial_stream(uno.port, uno.baud))
    async with Board.connect(stream, name=uno.port) as board:
        await arm(board)
        await uno.clear_pulse_stats("D4")
        resyncs = board.link.stats.resyncs
        # Only a resync's probe asks for the ID here (the keepalive polls the status).
        stream.drop_answer_to(p.ReadId().encode(), 1)
        stream.inject(p.ReadTemperatureReply(300).encode())
        replies_to_see = int((board.link.timeout + 0.25) / board.heartbeat_interval())
        with anyio.fail_after(10):
            await stream.dropped.wait()
            while stream.after_drop < replies_to_see * p.ReadStatusReply.LAYOUT.base_size:  # noqa: ASYNC110
                await anyio.sleep(0.05)
        assert board.link.stats.resyncs > resyncs
        d4 = await uno.pulse_stats("D4")
        assert d4.falls == 0 and d4.level == 1, f"the failsafe tripped on a healthy host: {d4}"
