"""The ``arduinoio`` bench commands as a user meets them, against virtual Unos."""

from __future__ import annotations

import io
import json
import logging
import os
import sys
from pathlib import Path

import anyio
import pytest
from anyio.streams.buffered import BufferedByteReceiveStream
from rich.console import Console

from arduinoio_async import Board, BoardTimeoutError, _resources
from arduinoio_async import protocol as p
from arduinoio_async.cli import main
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def run(*argv: str) -> tuple[int, str]:
    """Run the command in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=200)
    code = await anyio.to_thread.run_sync(lambda: main(list(argv), console=console))
    return code, buffer.getvalue()


async def test_read_reports_an_output_level_and_leaves_it_an_output(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    # loopback: D4 is jumpered to D5, so D5's level is the level D4 really drives.
    uno = await virtual_uno_factory(board_id=3, fixture="loopback")
    for level in (1, 0, 1):
        assert (await run("write", "--port", uno.port, "D4", str(level)))[0] == 0
        code, out = await run("read", "--port", uno.port, "D4")
        assert code == 0 and f"D4: level {level}" in out and "output" in out
        d4, d5 = await uno.pin("D4"), await uno.pin("D5")
        assert d4.ddr == 1 and d4.level == level and d5.level == level
    code, out = await run("status", "--port", uno.port, "--json")
    assert code == 0 and json.loads(out)["pins"] == {"D4": "digital output"}


async def arduinoio(*argv: str) -> tuple[int, str, str]:
    """The command in its own process, as a user runs it (its stderr is what they see)."""
    result = await anyio.run_process([sys.executable, "-m", "arduinoio_async", *argv], check=False)
    return result.returncode, result.stdout.decode(), result.stderr.decode()


async def test_an_asked_reset_is_no_lost_sync(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    assert (await arduinoio("write", "--port", uno.port, "D4", "1"))[0] == 0
    code, out, err = await arduinoio("reset", "--port", uno.port)
    assert code == 0 and "reset" in out, err
    assert (await uno.pin("D4")).ddr == 0  # the board really rebooted: D4 is free again
    code, out, err2 = await arduinoio("set-id", "--port", uno.port, "0x0004")
    assert code == 0 and "verified" in out, err2
    assert await uno.eeprom(0, 2) == b"\x00\x04"
    assert "lost sync" not in err + err2 and "ID probe" not in err + err2


async def test_a_real_loss_of_sync_is_still_a_warning(
    virtual_uno_factory: VirtualUnoFactory, caplog: pytest.LogCaptureFixture
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    async with Board.open(uno.port) as board:
        await board.reset()
        await uno.set_faults(drop=1.0)  # every byte to the host lost: the board goes quiet
        with caplog.at_level(logging.INFO, logger="arduinoio_async"):
            with pytest.raises(BoardTimeoutError):
                await board.request(p.ReadId(), timeout=0.2)
            await uno.set_faults(drop=0.0)
            assert await board.read_id() == 3
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert f"{uno.port} lost sync: ReadId timed out" in warnings


async def test_a_running_virtual_uno_is_found_without_naming_its_port(
    tmp_path: Path, virtual_uno_factory: VirtualUnoFactory
) -> None:
    await virtual_uno_factory()  # skips here when the simulator is missing
    env = {k: v for k, v in os.environ.items() if k != "ARDUINOIO_PORTS"}
    env["ARDUINOIO_REGISTRY_DIR"] = str(tmp_path / "registry")
    command = [sys.executable, "-m", "arduinoio_async"]
    sim = await anyio.open_process([*command, "sim", "--id", "0x0011"], env=env)
    try:
        assert sim.stdout is not None
        with anyio.fail_after(20):
            line = await BufferedByteReceiveStream(sim.stdout).receive_until(b"\n", 4096)
        port = json.loads(line)["port"]
        found = await anyio.run_process([*command, "info", "--json"], env=env, check=False)
        assert found.returncode == 0, found.stderr.decode()
        info = json.loads(found.stdout)
        assert info["id"] == 0x11 and info["port"] == port
    finally:
        sim.terminate()
        with anyio.fail_after(10):
            await sim.wait()
    assert sim.returncode == 0
    gone = await anyio.run_process([*command, "list"], env=env, check=False)
    assert gone.returncode == 1 and "no candidate ports" in gone.stderr.decode()


OPTIBOOT_HEX = Path(__file__).resolve().parents[2] / "firmware/bootloader/build/optiboot-1k.hex"


def optiboot() -> Path:
    """The optiboot image (``make bootloader``), or skip (fail with ARDUINOIO_SIM_REQUIRED)."""
    if not OPTIBOOT_HEX.is_file():
        if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
            pytest.fail(f"{OPTIBOOT_HEX} missing (make bootloader)")
        pytest.skip(f"{OPTIBOOT_HEX} missing (make bootloader)")
    return OPTIBOOT_HEX


async def test_a_board_with_only_its_bootloader_is_named_so(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(bootloader=optiboot())
    assert await uno.eeprom(0, 2) == b"\xff\xff"  # nothing but the bootloader
    code, _, err = await arduinoio("info", "--port", uno.port, "--probe-timeout", "1")
    assert code == 1
    assert "this board runs a bootloader only" in err and "arduinoio flash" in err, err
    assert "Traceback" not in err
    code, out, err = await arduinoio("flash", "--port", uno.port, "--id", "5")
    assert code == 0, err  # the diagnosis left the bootloader working
    assert "lost sync" not in err  # the flash's closing reset is no fault (item 7)
    code, out, err = await arduinoio("info", "--port", uno.port)
    assert code == 0 and "0x0005" in out, err


async def test_a_wrong_baud_rate_gets_the_baud_hint(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=6, baud=115200)
    code, _, err = await arduinoio("info", "--port", uno.port, "--probe-timeout", "1")
    assert code == 1
    assert "it sent nothing at 1000000 baud" in err and "--baud" in err, err
    assert "arduinoio flash" in err and "bootloader only" not in err
    code, out, err = await arduinoio("info", "--port", uno.port, "--baud", "115200")
    assert code == 0 and "0x0006" in out, err  # the hint was right


async def test_a_board_whose_bootloader_holds_a_program_gets_the_baud_hint(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    firmware = _resources.firmware_image(115200, "elf")
    uno = await virtual_uno_factory(bootloader=optiboot(), elf=firmware, baud=115200, board_id=7)
    code, _, err = await arduinoio("info", "--port", uno.port, "--probe-timeout", "1")
    assert code == 1
    assert "but its bootloader says it holds a program" in err and "--baud" in err, err
    assert "bootloader only" not in err
    code, out, err = await arduinoio("info", "--port", uno.port, "--baud", "115200")
    assert code == 0 and "0x0007" in out, err
