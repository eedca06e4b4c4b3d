"""``arduinoio flash`` end to end: the real avrdude, optiboot and the packaged firmware.

The virtual Uno runs optiboot (built by ``make bootloader`` from the source in Debian's
``arduino-core-avr``) from its boot section at 0x7C00 and resets into it when the port is
opened, as DTR does on a real Uno; avrdude writes the application with STK500 through
the pseudo-terminal, optiboot programs the flash with SPM and leaves through a watchdog
reset into the new firmware.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from arduinoio_async import Board, _resources
from arduinoio_async import protocol as p
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from tests.e2e.test_cli import run

pytestmark = pytest.mark.sim

OPTIBOOT_HEX = Path(__file__).resolve().parents[2] / "firmware/bootloader/build/optiboot-1k.hex"


def optiboot() -> Path:
    """The optiboot image for the virtual Uno, or skip (fail with ARDUINOIO_SIM_REQUIRED)."""
    missing = [] if shutil.which("avrdude") else ["avrdude"]
    if not OPTIBOOT_HEX.is_file():
        missing.append(f"{OPTIBOOT_HEX} (make bootloader)")
    if missing:
        if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
            pytest.fail(f"flashing tests need {', '.join(missing)}")
        pytest.skip(f"flashing tests need {', '.join(missing)}")
    return OPTIBOOT_HEX


async def test_flash_an_empty_board_then_it_answers_its_id(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(bootloader=optiboot())
    assert await uno.eeprom(0, 2) == b"\xff\xff"  # nothing but the bootloader
    code, out = await run("flash", "--port", uno.port, "--id", "5")
    assert code == 0, out
    assert "bytes, verified" in out and "0x0005 stored" in out
    async with Board.open(uno.port) as board:
        assert await board.read_id() == 5
        assert board.capabilities.baud == p.DEFAULT_BAUD


async def test_flash_over_running_firmware_resets_into_the_bootloader(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(
        bootloader=optiboot(), elf=_resources.firmware_image(p.DEFAULT_BAUD, "elf"), board_id=9
    )
    async with Board.open(uno.port) as board:  # the application runs after power-up
        assert await board.read_id() == 9
    code, out = await run("flash", "--port", uno.port, "--firmware-baud", "2000000")
    assert code == 0, out
    assert "arduinoio-2000000.hex" in out
    # The board now runs the 2,000,000-baud build: only that speed answers, ID kept.
    async with Board.open(uno.port, baudrate=2_000_000) as board:
        assert board.capabilities.baud == 2_000_000
        assert await board.read_id() == 9


async def test_dry_run_prints_the_avrdude_command(tmp_path: Path) -> None:
    code, out = await run("flash", "--port", "/dev/ttyACM7", "--baud", "57600", "--dry-run")
    assert code == 0
    image = _resources.firmware_image(p.DEFAULT_BAUD, "hex")
    assert "-c arduino -P /dev/ttyACM7 -b 57600 -D" in out
    assert f"flash:w:{image}:i" in out


async def test_avrdude_errors_are_shown(capsys: pytest.CaptureFixture[str]) -> None:
    if shutil.which("avrdude") is None:
        pytest.skip("avrdude is not installed")
    code, _ = await run("flash", "--port", "/dev/arduinoio-no-such-port")
    assert code == 1
    err = capsys.readouterr().err
    assert "avrdude failed" in err
    assert "/dev/arduinoio-no-such-port" in err  # avrdude's own line, not "Thank you."
    assert "Thank you" not in err
