"""The ``arduinoio`` bench commands as a user meets them, against virtual Unos (issue 25)."""

from __future__ import annotations

import io
import json

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
