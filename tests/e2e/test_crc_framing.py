"""CRC-16 framing on the real firmware (docs/protocol.md 7.7): negotiated at open, found
again after a reset, undone for a host that asks for the paper's framing, and never a
wrong answer on a bad line.  The oracle is the harness (pin levels, the analog input it
drives, the ID it stored), never the library's own answer."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import A1, D3, LinkError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import FRAMING_ENV

pytestmark = pytest.mark.sim


@pytest.fixture(autouse=True)
def ask_for_crc(monkeypatch: pytest.MonkeyPatch) -> None:
    """CRC-16 framing is asked for (the default is the paper's XOR framing)."""
    monkeypatch.setenv(FRAMING_ENV, "crc16")


async def test_a_board_with_crc_framing_is_switched_to_it_at_open(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0081, baud=1_000_000)
    trace: list[str] = []
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        board.link.trace = lambda record: trace.append(type(record.item).__name__)
        assert board.capabilities.features & p.Feature.CRC16
        assert board.link.framing is p.Framing.CRC16
        await board.digital_output(D3, initial=True)
        assert (await uno.pin(3)).level == 1
        assert await board.read_id() == 0x0081
        assert "Garbage" not in trace


async def test_a_reset_mid_session_falls_back_and_renegotiates(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0082, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud, timeout=0.3) as board:
        assert board.link.framing is p.Framing.CRC16
        switches = board.link.stats.framing_switches
        await uno.reset()  # the board boots in XOR framing
        with anyio.fail_after(10):
            while True:
                try:
                    if await board.read_id() == 0x0082:
                        break
                except LinkError:
                    continue
        assert board.link.framing is p.Framing.CRC16
        # found in XOR by the probe, then switched again
        assert board.link.stats.framing_switches >= switches + 2
        await board.digital_output(D3, initial=True)
        assert (await uno.pin(3)).level == 1


async def test_a_host_asking_for_xor_undoes_what_an_earlier_program_left(
    virtual_uno_factory: VirtualUnoFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    uno = await virtual_uno_factory(board_id=0x0083, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.link.framing is p.Framing.CRC16
    # the board keeps its framing while the port is closed (no reset on open)
    monkeypatch.setenv(FRAMING_ENV, "xor")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.link.framing is p.Framing.XOR
        assert await board.read_id() == 0x0083
    monkeypatch.setenv(FRAMING_ENV, "crc16")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.link.framing is p.Framing.CRC16
        assert await board.read_id() == 0x0083


async def test_no_wrong_answer_at_1e2_line_faults(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The short soak (benchmarks/crc_link.py runs 10^6 commands): 1 % of board->host bytes
    each dropped, inserted and flipped; every answer that returns is the fixture's."""
    uno = await virtual_uno_factory(board_id=0x0084, baud=1_000_000, seed=5)
    await uno.set_analog(1, 3000)
    async with Board.open(uno.port, baudrate=uno.baud, timeout=0.1) as board:
        assert board.link.framing is p.Framing.CRC16
        out = await board.digital_output(D3, initial=False)
        truth = await board.analog(A1).read()
        await uno.set_faults(drop=0.01, insert=0.01, flip=0.01)
        ok = failed = 0
        wrong: list[str] = []
        with anyio.fail_after(90):
            for step in range(600):
                try:
                    level = step % 2 == 0
                    await out.write(level)
                    if (await uno.pin(3)).level != int(level):
                        wrong.append(f"D3 written {level}")
                    if (value := await board.analog(A1).read()) != truth:
                        wrong.append(f"A1 read {value}, fixture {truth}")
                    if (board_id := await board.read_id()) != 0x0084:
                        wrong.append(f"ID {board_id:#x}")
                    ok += 1
                except LinkError:
                    failed += 1
        await uno.set_faults(drop=0, insert=0, flip=0)
        assert wrong == []
        assert ok > 300 and board.link.stats.resyncs > 0
        assert board.link.framing is p.Framing.CRC16
