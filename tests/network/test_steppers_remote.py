"""A stepper on a board served on the network (issue 26): the STEPPER requests pass through
the server untouched, its StepperDone events come back to the client that waits, and the
fixture counts the served board's step pulses."""

from __future__ import annotations

import pytest

from arduinoio_async import D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardError, FirmwareFeatureError
from arduinoio_async.network import open_remote_board

from ..e2e.steps import step_log, step_times
from .conftest import ServeFactory

pytestmark = pytest.mark.sim


async def test_a_remote_stepper_moves_exactly_and_reports_done(serve_unos: ServeFactory) -> None:
    async with (
        serve_unos([7]) as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        uno = served.unos[7]
        await step_log(uno, "D2")
        stepper = await board.stepper(step=D2, dir=D3, max_speed=3000, acceleration=30_000)
        await stepper.move_to(-1200)
        state = await stepper.wait(timeout=10)
        assert state.position == -1200 and not state.moving
        times, _ = await step_times(uno, "D2")
        assert len(times) == 1200
        assert stepper.last_done is not None  # the event crossed the network
        assert stepper.last_done.reason is p.StepperDoneReason.TARGET


async def test_a_second_client_cannot_release_a_remote_steppers_pin(
    serve_unos: ServeFactory,
) -> None:
    async with (
        serve_unos([7]) as served,
        open_remote_board(7, connect=[served.endpoint]) as first,
        open_remote_board(7, connect=[served.endpoint]) as second,
    ):
        stepper = await first.stepper(step=D2, dir=D3)
        with pytest.raises(BoardError, match="the pin is busy"):
            await second.release(D3)  # the server knows D3 is the first client's stepper's
        assert (await stepper.read()).position == 0  # still configured on the board


async def test_a_served_image_without_steppers_is_refused_at_the_client(
    serve_unos: ServeFactory,
) -> None:
    """The features word crosses the network: a remote client of a sensing image gets the
    same FirmwareFeatureError as a local one, before anything is sent; a raw request sent
    anyway comes back from the served board as NOT_IN_IMAGE, and the pins stay free."""
    async with (
        serve_unos([7], profile="sensing") as served,
        open_remote_board(7, connect=[served.endpoint]) as board,
    ):
        assert not board.capabilities.features & p.Feature.STEPPER
        with pytest.raises(FirmwareFeatureError, match="arduinoio flash --profile standard"):
            await board.stepper(step=D2, dir=D3)
        with pytest.raises(BoardError) as answered:
            await board.request(p.StepperConfig(0, int(D2), int(D3)))
        assert answered.value.code is p.ErrorCode.NOT_IN_IMAGE
        await board.digital_output(D2)  # nothing took the pin
        assert (await served.unos[7].pin("D2")).ddr == 1
