"""Transactions on the virtual Uno (protocol extension, docs/protocol.md 7.5)."""

from __future__ import annotations

import pytest

from arduinoio_async import D2, D3, D4, D5, D6, D7
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import BoardError
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import fresh_pulses

pytestmark = pytest.mark.sim


async def test_write_d2_and_read_its_jumper_d3_in_one_frame(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.digital_output(D2)
        await board.digital_input(D3)
        for level in (True, False, True, False):
            async with board.transaction() as tx:
                before = tx.add(p.GpioRead(D3))
                tx.add(p.GpioWrite(D2, level))
                after = tx.add(p.GpioRead(D3))
                refused = tx.add(p.GpioWrite(D3, level))  # an input: refused, alone
            assert before.result().level is not level  # read before the write ran
            assert after.result().level is level  # and after it, through the jumper
            with pytest.raises(BoardError):
                refused.result()
        status = await uno.status()
        assert status["lost"] == {"to_board": 0, "to_host": 0}


async def test_six_servo_widths_at_once_are_measured_by_the_fixture(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    pins = (D2, D3, D4, D5, D6, D7)
    widths = (1000, 1200, 1400, 1600, 1800, 2000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        for pin in pins:
            await board.soft_pwm(pin)  # type: ignore[arg-type]
        async with board.transaction() as tx:
            items = [tx.add(p.PwmSet(pin, width)) for pin, width in zip(pins, widths, strict=True)]
        assert [item.result().pulse_us for item in items] == list(widths)
        for pin, width in zip(pins, widths, strict=True):
            stats = await fresh_pulses(uno, pin.name, 2)
            assert all(abs(h - width) <= 4 for h in stats.high_us), (pin, stats.high_us)
