"""Each shipped Uno image holds what its build profile says, and says so.

The oracle is the firmware image itself running on the virtual Uno: its capabilities'
features word and its replies to a class it leaves out.  The profile table
(arduinoio_async/protocol/profiles.py) is what the images are compared with, so a
Makefile that built the wrong switches, or a module compiled in by mistake, fails here.
"""

from __future__ import annotations

import io

import anyio
import pytest
from rich.console import Console

from arduinoio_async import D2, D3
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import BoardError, FirmwareFeatureError
from arduinoio_async.protocol.profiles import OPTIONAL_FEATURES, UNO_PROFILES, profile
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: An Uno image without steppers, and the one that has them.
WITHOUT_STEPPERS, WITH_STEPPERS = "sensing", "standard"


def optional_bits(features: int) -> set[str]:
    """The optional classes a features word announces (names known to the protocol)."""
    return {
        name
        for name in OPTIONAL_FEATURES
        if name in p.Feature.__members__ and features & p.Feature[name]
    }


@pytest.mark.parametrize("name", UNO_PROFILES)
async def test_each_image_announces_exactly_its_profiles_classes(
    virtual_uno_factory: VirtualUnoFactory, name: str
) -> None:
    uno = await virtual_uno_factory(profile=name)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        features = board.capabilities.features
    wanted = {f for f in profile(name).features if f in p.Feature.__members__}
    assert optional_bits(features) == wanted
    assert features & p.Feature.GPIO and features & p.Feature.STREAM
    assert features & p.Feature.FAILSAFE and features & p.Feature.DUTY_PWM


async def test_an_image_without_steppers_refuses_them_before_sending_and_on_the_wire(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The library refuses from the features word, naming the image that has steppers;
    a request sent anyway gets NOT_IN_IMAGE from the board (an ordinary error reply: the
    link goes on) and leaves the pins free."""
    assert not profile(WITHOUT_STEPPERS).has("STEPPER")
    uno = await virtual_uno_factory(profile=WITHOUT_STEPPERS)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(FirmwareFeatureError) as refused:
            await board.stepper(step=D2, dir=D3)
        text = str(refused.value)
        assert "steppers" in text
        assert f"'{WITH_STEPPERS}'" in text and f"--profile {WITH_STEPPERS}" in text
        assert D2 not in board.roles and D3 not in board.roles
        with pytest.raises(FirmwareFeatureError):
            async with board.stream(steppers=True, period_ms=10):
                pass
        with pytest.raises(BoardError) as answered:
            await board.request(p.StepperConfig(0, int(D2), int(D3)))
        assert answered.value.code is p.ErrorCode.NOT_IN_IMAGE
        assert await board.read_id() == board.board_id  # the link went on in order
        # the board gave the pins to nothing: both take another role at once
        await board.digital_output(D2)
        await board.digital_input(D3)


async def test_cli_names_the_image_to_flash(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(profile=WITHOUT_STEPPERS)
    console = Console(file=io.StringIO(), width=200)
    argv = ["stepper", "D2", "D3", "--by", "10", "--port", uno.port, "--baud", str(uno.baud)]
    code = await anyio.to_thread.run_sync(lambda: cli_main(argv, console=console))
    err = capsys.readouterr().err
    assert code == 1, err  # docs/howto/command-line.md: the board or the request refused
    assert f"arduinoio flash --profile {WITH_STEPPERS}" in err
    assert len(err.strip().splitlines()) == 1
