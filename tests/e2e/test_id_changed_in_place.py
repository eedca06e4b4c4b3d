"""A board whose ID changed in place is not restored under its old ID.

A raw ``WriteId`` (not ``Board.write_id``) changes the board's EEPROM behind the library's
back; after the next reset the manager used to adopt the board as the old ID, replay the
old board's pin roles on it, and every ``read_id()`` then failed with "line noise
destroyed the reply" (the link expected the old ID).  The fixture is the oracle: D4, an
output held high by board 0x0011's role, must not be driven by the board that now answers
as 0x0022.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D4, BoardDisconnectedError
from arduinoio_async import protocol as p
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

OLD, NEW = 0x0011, 0x0022


async def test_a_board_whose_id_changed_is_listed_under_the_new_id_without_old_roles(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=OLD)
    events: list[ManagerEvent] = []
    async with BoardManager(ports=[uno.port], usb=False, env=False) as boards:
        boards.subscribe(events.append)
        old = await boards.get(OLD)
        await old.digital_output(D4, initial=True)
        assert (await uno.pin("D4")).ddr == 1
        await old.request(p.WriteId(NEW))  # raw: the library's records still say 0x0011
        await uno.reset()
        with anyio.fail_after(10):
            new = await boards.wait_connected(NEW)
        assert new is not old
        assert await new.read_id() == NEW
        assert set(boards.present()) == {NEW}
        assert not old.connected
        with pytest.raises(BoardDisconnectedError):
            await old.read_id()
        # The old board's D4 role was not replayed on the board that answers as 0x0022.
        pin = await uno.pin("D4")
        assert pin.ddr == 0 and pin.port == 0, pin
        assert not new.roles.setups()
        kinds = [(e.kind, e.board_id) for e in events]
        assert ("disconnected", OLD) in kinds and kinds[-1] == ("connected", NEW), kinds


async def test_write_id_rekeys_the_board_in_the_manager(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """``Board.write_id`` changes the ID on purpose: the same board (and its roles) is then
    listed, found and restored under the new ID."""
    uno = await virtual_uno_factory(board_id=OLD)
    events: list[ManagerEvent] = []
    async with BoardManager(ports=[uno.port], usb=False, env=False) as boards:
        boards.subscribe(events.append)
        board = await boards.get(OLD)
        await board.digital_output(D4, initial=True)
        await board.write_id(NEW)
        assert set(boards.present()) == {NEW}
        assert await boards.get(NEW, timeout=1) is board
        await uno.reset()
        with anyio.fail_after(10):
            while not any(e.kind == "reset" for e in events):  # noqa: ASYNC110
                await anyio.sleep(0.02)
            assert await boards.wait_connected(NEW) is board
            while (await uno.pin("D4")).level != 1:  # noqa: ASYNC110 - the role is replayed
                await anyio.sleep(0.02)
        assert await board.read_id() == NEW
        assert set(boards.present()) == {NEW}
