"""The framing negotiation through the transport, against FakeBoard: an old firmware
keeps the paper's framing, a reboot falls back and renegotiates, a board left in CRC-16
framing is taken back to XOR by the open's ready check."""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D4, LinkError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport import FRAMING_ENV


@pytest.fixture(autouse=True)
def ask_for_crc(monkeypatch: pytest.MonkeyPatch) -> None:
    """CRC-16 framing is asked for (the default is the paper's XOR framing)."""
    monkeypatch.setenv(FRAMING_ENV, "crc16")


async def test_by_default_the_link_keeps_the_papers_framing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(FRAMING_ENV)
    async with (
        FakeBoard(board_id=0x20) as fake,
        Board.connect(fake.host_stream) as board,
    ):
        assert board.capabilities.features & p.Feature.CRC16
        assert board.link.framing is p.Framing.XOR and fake.framing is p.Framing.XOR
        assert await board.read_id() == 0x20


async def test_old_firmware_without_the_bit_keeps_working_in_xor() -> None:
    async with (
        FakeBoard(board_id=0x21, crc_capable=False) as fake,
        Board.connect(fake.host_stream) as board,
    ):
        assert not board.capabilities.features & p.Feature.CRC16
        assert board.link.framing is p.Framing.XOR
        await board.digital_output(D4, initial=True)
        assert fake.levels[4]
        assert await board.read_id() == 0x21
        assert fake.framing is p.Framing.XOR


async def test_both_ends_switch_and_a_reboot_falls_back_then_renegotiates() -> None:
    async with (
        FakeBoard(board_id=0x22) as fake,
        Board.connect(fake.host_stream, timeout=0.2) as board,
    ):
        assert board.link.framing is p.Framing.CRC16 and fake.framing is p.Framing.CRC16
        fake.reboot()
        assert fake.framing.name == "XOR"
        with anyio.fail_after(10):
            while True:
                try:
                    assert await board.read_id() == 0x22
                    break
                except LinkError:
                    continue
        assert board.link.framing is p.Framing.CRC16 and fake.framing is p.Framing.CRC16
        await board.digital_output(D4, initial=True)
        assert fake.levels[4]


@pytest.mark.parametrize("framing", ["xor", "crc16"])
async def test_a_board_left_in_crc_framing_opens_in_the_framing_asked_for(
    framing: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(FRAMING_ENV, framing)
    async with (
        FakeBoard(board_id=0x23, framing=p.Framing.CRC16) as fake,
        Board.connect(fake.host_stream) as board,
    ):
        assert board.link.framing is p.Framing[framing.upper()]
        assert fake.framing is board.link.framing
        assert await board.read_id() == 0x23


def test_a_bad_framing_setting_is_a_precise_error(monkeypatch: pytest.MonkeyPatch) -> None:
    from arduinoio_async.errors import UsageError
    from arduinoio_async.transport import default_framing

    monkeypatch.setenv(FRAMING_ENV, "crc32")
    with pytest.raises(UsageError, match="ARDUINOIO_FRAMING='crc32': use crc16 or xor"):
        default_framing()
