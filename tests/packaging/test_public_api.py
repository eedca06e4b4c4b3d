"""The names a robot program imports from the package itself, and what they are."""

from __future__ import annotations

import arduinoio_async
from arduinoio_async import D3, D9, Board, FakeBoard, VirtualUno
from arduinoio_async import protocol as p


def test_every_public_name_resolves_to_its_defining_module() -> None:
    for name in arduinoio_async.__all__:
        assert getattr(arduinoio_async, name) is not None, name
    from arduinoio_async.board import Board as DefinedBoard
    from arduinoio_async.sim import VirtualUno as DefinedVirtualUno

    assert Board is DefinedBoard and VirtualUno is DefinedVirtualUno
    assert set(arduinoio_async.__all__) <= set(dir(arduinoio_async))


async def test_the_fake_board_reports_pin_roles_like_the_firmware() -> None:
    async with FakeBoard(board_id=7) as fake, Board.connect(fake.host_stream) as board:
        await board.digital_input(D3)
        await board.servo(D9, pulse_us=1500)
        roles = await board.request(p.ReadPinRoles())
        assert roles == p.ReadPinRolesReply(1 << 3, 0, 1 << 9, 0, 0)
        await board.release(D3)
        assert (await board.request(p.ReadPinRoles())).gpio_input == 0
