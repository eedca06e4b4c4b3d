"""Low-latency mode with FakeBoard (protocol extension, docs/protocol.md 7.6): the fake
pads its replies with filler as the firmware does, and no caller ever sees a filler byte.
The virtual Uno counterpart with the 16U2 bridge model is ``tests/e2e/test_low_latency.py``.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import ProtocolError
from arduinoio_async.testing import FakeBoard


async def test_many_concurrent_callers_get_their_replies_and_never_filler() -> None:
    async with FakeBoard(board_id=0x0203) as fake, Board.connect(fake.host_stream) as board:
        assert board.capabilities.features & p.Feature.LOW_LATENCY
        await board.set_low_latency(True)
        assert fake.low_latency and board.low_latency
        out = await board.digital_output(D2)
        results: list[object] = []

        async def caller(n: int) -> None:
            for i in range(n):
                if i % 2:
                    results.append(await board.read_id())
                else:
                    await out.write(bool(i % 4))
                    results.append("written")

        async with anyio.create_task_group() as tg:
            for _ in range(16):
                tg.start_soon(caller, 10)
        assert results.count(0x0203) == 80 and results.count("written") == 80
        assert fake.filler_sent >= 160 * (p.LOW_LATENCY_PAD - 6)  # filler did flow
        assert board.link.stats.garbage_bytes == 0 and board.link.stats.resyncs == 0
        sent = fake.filler_sent
        await board.set_low_latency(False)
        assert not fake.low_latency and not board.low_latency
        assert await board.read_id() == 0x0203
        assert fake.filler_sent == sent


async def test_cancelled_callers_leave_the_link_aligned_in_low_latency_mode() -> None:
    async with FakeBoard(board_id=9) as fake, Board.connect(fake.host_stream) as board:
        await board.set_low_latency(True)
        with anyio.move_on_after(0):  # cancelled before or while its request is out
            await board.read_id()
        async with anyio.create_task_group() as tg:
            for _ in range(8):
                tg.start_soon(board.read_id)
            tg.cancel_scope.cancel()
        assert await board.read_id() == 9
        assert board.link.stats.garbage_bytes == 0
        assert fake.filler_sent > 0


async def test_the_mode_is_replayed_after_a_reset() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        await board.set_low_latency(True)
        await board.reset(restore=True)
        assert fake.low_latency  # the fake forgot it at reset; restore() set it again
        inp = await board.digital_input(D3)
        assert (await inp.read()).level is False
        assert board.link.stats.garbage_bytes == 0


async def test_a_board_without_the_feature_bit_refuses_with_a_precise_error() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        caps = board.capabilities
        board.capabilities = p.ReadCapabilitiesReply(
            caps.protocol_version,
            caps.firmware_major,
            caps.firmware_minor,
            caps.features & ~p.Feature.LOW_LATENCY,
            caps.baud,
            caps.rx_buffer,
        )
        with pytest.raises(ProtocolError, match="low-latency"):
            await board.set_low_latency(True)
        assert not fake.low_latency and not board.low_latency
