"""``Board.adopt`` checks that a fresh boot is still the same board."""

from __future__ import annotations

import pytest

from arduinoio_async import D4
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardIdChangedError

from .fake_boards import connected


async def test_adopt_refuses_a_board_whose_id_changed_and_replays_nothing() -> None:
    async with connected(0x0011) as (board, fake):
        await board.digital_output(D4, initial=True)
        await board.request(p.WriteId(0x0022))  # raw: behind the Board's back
        fake.reboot()
        seen = fake.requests_seen
        with pytest.raises(BoardIdChangedError) as caught:
            await board.adopt(board.link)
        assert (caught.value.old_id, caught.value.new_id) == (0x0011, 0x0022)
        assert fake.role(4) == "free"  # 0x0011's role was not replayed
        assert fake.requests_seen - seen == 2  # the ID, asked twice; nothing else
        assert not board.connected


async def test_adopt_restores_the_same_board_after_a_reset() -> None:
    async with connected(0x0011) as (board, fake):
        await board.digital_output(D4, initial=True)
        fake.reboot()
        await board.adopt(board.link)
        assert fake.role(4) == "output" and fake.levels[4]
        assert await board.read_id() == 0x0011
