"""The ``arduinoio`` command against virtual Unos, through ``main(argv)``."""

from __future__ import annotations

import io
import json
from pathlib import Path

import anyio
import pytest
from rich.console import Console

from arduinoio_async.cli import main
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def run(*argv: str) -> tuple[int, str]:
    """Run the command in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=200)
    code = await anyio.to_thread.run_sync(lambda: main(list(argv), console=console))
    return code, buffer.getvalue()


async def test_list_finds_the_boards(virtual_uno_factory: VirtualUnoFactory) -> None:
    one = await virtual_uno_factory(board_id=1)
    two = await virtual_uno_factory(board_id=2)
    code, out = await run("list", "--json", "--ports", one.port, "--ports", two.port)
    assert code == 0
    rows = {row["port"]: row for row in json.loads(out)}
    assert rows[one.port]["id"] == 1 and rows[two.port]["id"] == 2
    assert rows[one.port]["protocol"] == 1 and rows[one.port]["baud"] == 115200
    code, out = await run("list", "--ports", one.port)
    assert code == 0 and "0x0001" in out


async def test_info_and_missing_id(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(board_id=2)
    code, out = await run("info", "--id", "2", "--ports", uno.port)
    assert code == 0 and "0x0002" in out and "temperature" in out
    code, _ = await run("info", "--id", "0x99", "--ports", uno.port, "--probe-timeout", "1")
    assert code == 1
    assert "no board with ID 0x0099" in capsys.readouterr().err


async def test_pin_commands_change_the_fixture(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, out = await run("write", "--port", uno.port, "D4", "1")
    assert code == 0 and (await uno.pin("D4")).level == 1
    await uno.drive("D5", 1)
    code, out = await run("read", "--port", uno.port, "D5")
    assert code == 0 and "level 1" in out
    code, _ = await run("servo", "--port", uno.port, "D9", "1500")
    assert code == 0 and (await uno.pin("D9")).ddr == 1
    code, _ = await run("servo", "--port", uno.port, "D6", "1200")
    assert code == 0
    await uno.set_analog(0, 2500)
    code, out = await run("analog", "--port", uno.port, "A0")
    assert code == 0 and "A0: 51" in out
    code, out = await run("analog", "--port", uno.port)
    assert code == 0 and "A5:" in out


async def test_i2c_write_and_read(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, _ = await run("i2c", "write", "0x50", "0x10", "1", "2", "3", "--port", uno.port)
    assert code == 0
    code, out = await run("i2c", "read", "0x50", "0x10", "3", "--port", uno.port)
    assert code == 0 and "01 02 03" in out


async def test_set_id_verifies_after_reset(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, out = await run("set-id", "--port", uno.port, "0x0002")
    assert code == 0 and "verified" in out
    assert await uno.eeprom(0, 2) == b"\x00\x02"


async def test_errors_are_one_line_and_a_nonzero_code(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, _ = await run("servo", "--port", uno.port, "D8", "1500")
    assert code == 1
    err = capsys.readouterr().err
    assert "software PWM is available on D2, D3, D4, D5, D6, D7" in err
    assert "Traceback" not in err
    code, _ = await run("servo", "--port", uno.port, "D9", "2500")
    assert code == 1 and "1000-2000" in capsys.readouterr().err
    code, _ = await run("write", "--port", "/dev/does-not-exist", "D2", "1")
    assert code == 1 and "cannot open /dev/does-not-exist" in capsys.readouterr().err
    code, _ = await run("flash", "--port", uno.port, "--hex", str(tmp_path / "missing.hex"))
    assert code == 2 and "does not exist" in capsys.readouterr().err
