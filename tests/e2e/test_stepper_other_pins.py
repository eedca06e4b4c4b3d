"""A moving stepper touches only its own pins: the board tick that drives it writes no
other pin (a timing probe once left in ``stepper_tick`` toggled D12 every tick).

The oracle is the fixture's: D12's rising edges logged by the harness while the stepper
moves, and the level the circuit sees on D12 afterwards.
"""

from __future__ import annotations

import pytest

from arduinoio_async import D2, D3, D12
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .steps import step_count, step_log, step_times

pytestmark = pytest.mark.sim


async def test_a_moving_stepper_leaves_another_handles_output_alone(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        held = await board.digital_output(D12, initial=True)
        stepper = await board.stepper(step=D2, dir=D3, max_speed=5000, acceleration=50_000)
        await step_log(uno, "D2", "D12")
        await stepper.move_to(2000)
        await stepper.wait(timeout=20)
        assert len((await step_times(uno, "D2"))[0]) == 2000  # the ticks ran
        assert await step_count(uno, "D12") == 0  # D12 never fell and rose again
        assert (await uno.pin("D12")).level == 1
        await held.write(True)  # the handle still owns its pin
