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
    core = features & ~sum(p.Feature[f] for f in OPTIONAL_FEATURES if f in p.Feature.__members__)
    assert core & p.Feature.GPIO and core & p.Feature.STREAM and core & p.Feature.FAILSAFE


async def test_an_image_without_encoders_refuses_them_before_sending_and_on_the_wire(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The library refuses from the features word, naming the images that have encoders;
    a request sent anyway gets NOT_IN_IMAGE from the board (an ordinary error reply: the
    link goes on) and leaves the pins free."""
    uno = await virtual_uno_factory(profile="motion")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(FirmwareFeatureError) as refused:
            await board.encoder(D2, D3)
        text = str(refused.value)
        assert "quadrature encoders" in text
        assert "'standard'" in text and "arduinoio flash --profile standard" in text
        assert D2 not in board.roles
        with pytest.raises(FirmwareFeatureError):
            async with board.stream(encoders=True, period_ms=10):
                pass
        with pytest.raises(BoardError) as answered:
            await board.request(p.EncoderConfig(0, int(D2), int(D3), p.EncoderMode.X4))
        assert answered.value.code is p.ErrorCode.NOT_IN_IMAGE
        assert await board.read_id() == board.board_id  # the link went on in order
        # the board gave the pins to nothing: both take another role at once
        await board.digital_output(D2)
        await board.digital_input(D3)


async def test_cli_names_the_image_to_flash(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(profile="motion")
    console = Console(file=io.StringIO(), width=200)
    argv = ["encoder", "D2", "D3", "--port", uno.port, "--baud", str(uno.baud), "--seconds", "0"]
    code = await anyio.to_thread.run_sync(lambda: cli_main(argv, console=console))
    err = capsys.readouterr().err
    assert code == 1, err  # docs/howto/command-line.md: the board or the request refused
    assert "arduinoio flash --profile standard" in err
    assert len(err.strip().splitlines()) == 1
