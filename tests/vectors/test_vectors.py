"""Run the shared vectors against FakeBoard and the real firmware on a virtual Uno.

The firmware's host tests run the same vectors from the generated ``vectors.h``
(``make -C firmware test``); ``test_generated_c_array_is_current`` keeps that in step.
"""

from __future__ import annotations

import collections
from collections.abc import Awaitable, Callable

import anyio
import anyio.abc
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport._serial import open_serial_stream

from .vectors import C_HEADER, Drive, VectorFile, load_all, render_c_header

VECTORS = load_all()
BAUD = 115200  # the capacity vectors state the paper's baud


class RawLink:
    """Frames to a board and its replies as bytes; board-initiated frames are skipped."""

    def __init__(self, stream: anyio.abc.ByteStream) -> None:
        self.stream = stream
        self.decoder = p.Decoder.from_board()
        self.pending: collections.deque[p.Decoded] = collections.deque()

    def set_framing(self, crc: bool) -> None:
        """Decode the next replies in CRC-16 (``crc``) or XOR framing."""
        if (self.decoder.framing is p.Framing.CRC16) != crc:
            self.decoder = p.Decoder.from_board(framing=p.Framing.CRC16 if crc else p.Framing.XOR)

    async def exchange(self, request: bytes, timeout: float = 2.0) -> bytes:
        await self.stream.send(request)
        crc = self.decoder.framing is p.Framing.CRC16
        with anyio.fail_after(timeout):
            while True:
                while self.pending:
                    item = self.pending.popleft()
                    if isinstance(item, p.Garbage):
                        return item.data
                    if not isinstance(item, p.Event):
                        return p.crc_framed(item.encode()) if crc else item.encode()
                self.pending.extend(self.decoder.feed(await self.stream.receive()))


Drive_ = Callable[[int, bool], Awaitable[None]]


async def run_vectors(vf: VectorFile, link: RawLink, drive: Drive_) -> None:
    for step in vf.steps:
        if isinstance(step, Drive):
            await drive(step.pin, step.level)
            continue
        link.set_framing(step.crc)
        got = await link.exchange(step.request)
        assert step.matches(got), f"{vf.name}.vec {step.describe()}: got {got.hex(' ').upper()}"


@pytest.mark.parametrize("vf", VECTORS, ids=[vf.name for vf in VECTORS])
async def test_fake_board(vf: VectorFile) -> None:
    async with FakeBoard(board_id=vf.board_id, baud=BAUD) as fake:

        async def drive(pin: int, level: bool) -> None:
            fake.drive(pin, level)

        await run_vectors(vf, RawLink(fake.host_stream), drive)


@pytest.mark.sim
@pytest.mark.parametrize("vf", VECTORS, ids=[vf.name for vf in VECTORS])
async def test_virtual_uno(vf: VectorFile, virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=vf.board_id, baud=BAUD, profile=vf.profile)
    stream = await open_serial_stream(uno.port, BAUD)
    try:
        link = RawLink(stream)
        await wait_answering(link)

        async def drive(pin: int, level: bool) -> None:
            """Drive, then let 50 us of simulated time pass: the pin-change interrupt must
            see each level (two drives applied in one slice would look like none)."""
            await uno.drive(pin, level)
            start = (await uno.status())["sim_us"]
            with anyio.fail_after(5):
                while (await uno.status())["sim_us"] < start + 50:
                    await anyio.lowlevel.checkpoint()

        await run_vectors(vf, link, drive)
    finally:
        await stream.aclose()


async def wait_answering(link: RawLink) -> None:
    """Until the firmware's receiver is on: a read-ID probe, repeated, each with a deadline."""
    probe = p.ReadId().encode()
    with anyio.fail_after(5):
        while True:
            with anyio.move_on_after(0.1):
                if isinstance(p.Decoder.from_board().feed(await link.exchange(probe))[0], p.Frame):
                    return
            link.decoder.reset()
            link.pending.clear()


def test_generated_c_array_is_current() -> None:
    assert C_HEADER.read_text() == render_c_header(VECTORS), (
        "firmware/tests/vectors.h is stale: run `python -m tests.vectors.vectors`"
    )
