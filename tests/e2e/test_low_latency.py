"""Low-latency mode behind the 16U2 bridge model (protocol extension, docs/protocol.md 7.6).

The virtual Uno's 16U2 model holds board-to-host bytes until its 4.096 ms tick or until
more than 96 wait; in low-latency mode the firmware pads each burst of replies with
filler so the bridge sends at once.  Latency goals are measured by
``benchmarks/low_latency.py``, not asserted here: these tests check that the mode works
and that filler never reaches a caller.
"""

from __future__ import annotations

import pytest

from arduinoio_async import D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from tests.fake_boards import read_ids_concurrently

pytestmark = pytest.mark.sim


@pytest.mark.parametrize("baud", [1000000, 2000000])
async def test_read_id_in_low_latency_mode_behind_the_16u2_model(
    virtual_uno_factory: VirtualUnoFactory, baud: int
) -> None:
    uno = await virtual_uno_factory(
        board_id=0x0102, baud=baud, usb_bridge="16u2", fixture="loopback"
    )
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.capabilities.features & p.Feature.LOW_LATENCY
        await board.set_low_latency(True)
        assert board.low_latency
        d2 = await board.digital_output(D2)
        d3 = await board.digital_input(D3)
        assert await read_ids_concurrently(board) == [0x0102] * 80  # pipelined callers
        for level in (True, False, True):  # other replies are unaffected by the filler
            await d2.write(level)
            assert (await d3.read()).level is level
        stats = board.link.stats
        assert stats.garbage_bytes == 0 and stats.resyncs == 0  # filler is never garbage
        await board.set_low_latency(False)
        assert await board.read_id() == 0x0102
        assert board.link.stats.resyncs == 0
        status = await uno.status()
        assert status["lost"] == {"to_board": 0, "to_host": 0}


async def test_low_latency_mode_is_replayed_after_a_reset(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=7, baud=2000000, usb_bridge="16u2")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.set_low_latency(True)
        await board.reset(restore=True)
        # the board forgot the mode at boot; restore() sent it again: asking for it
        # once more answers "on" and the link sees no garbage
        reply = await board.request(p.SetLowLatency(True))
        assert reply.enabled is True and board.low_latency
        assert await board.read_id() == 7
        assert board.link.stats.garbage_bytes == 0
