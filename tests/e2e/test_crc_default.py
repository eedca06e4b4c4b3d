"""Which framing a link asks for when the program does not say (docs/protocol.md 7.7):
CRC-16 behind a bridge that holds replies for a timer tick (an Uno's 16U2, known by its
USB IDs), where the two extra bytes cost about 1 % of a round trip; the paper's XOR on
any other link (a direct UART, a pseudo-terminal), where they cost more than 5 % at
1,000,000 baud; ``ARDUINOIO_FRAMING`` overrides both.  The virtual Uno's pseudo-terminal
stands for the 16U2's port through pyserial's port list (as ``list_ports`` reports an
Uno R3); the oracle for the framing in force is the board's own answer to a frame in it
(the harness pin it drives), not only the library's state."""

from __future__ import annotations

import os

import pytest
from serial.tools import list_ports

from arduinoio_async import D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import FRAMING_ENV

pytestmark = pytest.mark.sim


class _Port:
    """What pyserial's list_ports reports for one port."""

    def __init__(self, device: str, vid: int | None, pid: int | None) -> None:
        self.device, self.vid, self.pid = device, vid, pid


def behind(monkeypatch: pytest.MonkeyPatch, port: str, vid: int, pid: int) -> None:
    devices = [_Port(os.path.realpath(port), vid, pid)]
    monkeypatch.setattr(list_ports, "comports", lambda: devices)


@pytest.fixture(autouse=True)
def no_framing_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(FRAMING_ENV, raising=False)


async def test_a_board_behind_an_uno_16u2_gets_crc_framing_by_default(
    virtual_uno_factory: VirtualUnoFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    uno = await virtual_uno_factory(board_id=0x0091, baud=1_000_000)
    behind(monkeypatch, uno.port, 0x2341, 0x0043)  # Uno R3: ATmega16U2
    async with Board.open(uno.port, baudrate=uno.baud, low_latency=False) as board:
        assert board.link.framing is p.Framing.CRC16
        await board.digital_output(D3, initial=True)  # a CRC-framed request the board took
        assert (await uno.pin(3)).level == 1
        assert await board.read_id() == 0x0091


@pytest.mark.parametrize("vid_pid", [(0x1A86, 0x7523), None], ids=["ch340", "pty"])
async def test_any_other_link_keeps_the_papers_framing_by_default(
    virtual_uno_factory: VirtualUnoFactory,
    monkeypatch: pytest.MonkeyPatch,
    vid_pid: tuple[int, int] | None,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0092, baud=1_000_000)
    if vid_pid is not None:
        behind(monkeypatch, uno.port, *vid_pid)
    async with Board.open(uno.port, baudrate=uno.baud, low_latency=False) as board:
        assert board.link.framing is p.Framing.XOR
        assert await board.read_id() == 0x0092


async def test_the_environment_overrides_the_bridges_default(
    virtual_uno_factory: VirtualUnoFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    uno = await virtual_uno_factory(board_id=0x0093, baud=1_000_000)
    behind(monkeypatch, uno.port, 0x2341, 0x0043)
    monkeypatch.setenv(FRAMING_ENV, "xor")
    async with Board.open(uno.port, baudrate=uno.baud, low_latency=False) as board:
        assert board.link.framing is p.Framing.XOR
        assert await board.read_id() == 0x0093


async def test_crc_framing_and_low_latency_mode_together_through_the_16u2_model(
    virtual_uno_factory: VirtualUnoFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The configuration the defaults now pick for an Uno R3 at 1 Mbaud: CRC-16 frames and
    filler after each burst, through the bridge's 4.096 ms tick (the harness's model)."""
    uno = await virtual_uno_factory(board_id=0x0094, baud=1_000_000, usb_bridge="16u2")
    behind(monkeypatch, uno.port, 0x2341, 0x0043)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        assert board.link.framing is p.Framing.CRC16
        assert board.low_latency
        out = await board.digital_output(D3)
        for level in (True, False, True):
            await out.write(level)
            assert (await uno.pin(3)).level == int(level)
        assert [await board.read_id() for _ in range(20)] == [0x0094] * 20
        assert board.link.stats.garbage_bytes == 0
