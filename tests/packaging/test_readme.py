"""Every ```python block of README.md runs against virtual Unos, so the README cannot drift.

Board 0x0001 stands in for ``/dev/ttyACM0`` and boards 0x0001/0x0002 are what
``BoardManager()`` finds (through ``ARDUINOIO_PORTS``).  A complete program (one that
calls ``anyio.run``) runs as it is; a fragment runs inside ``async def main()``, with
``board`` opened on board 0x0001 unless the fragment opens it itself, and ``control``
standing for the reader's own code.  Each block runs in its own Python process, as a
user's script would.
"""

from __future__ import annotations

import os
import re
import sys
import textwrap
from pathlib import Path

import anyio
import pytest

from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", README.read_text(), re.DOTALL | re.MULTILINE)

FRAGMENT = """\
import anyio
from arduinoio_async import *


def control(*values: object) -> None:
    pass


async def main() -> None:
{open_board}{body}


anyio.run(main)
"""


def script_for(block: str, port: str) -> str:
    code = block.replace("/dev/ttyACM0", port)
    if "anyio.run(" in code:
        return code
    opens_board = "Board.open(" in code
    indent = "    " if opens_board else "        "
    open_board = "" if opens_board else f"    async with Board.open({port!r}) as board:\n"
    return FRAGMENT.format(open_board=open_board, body=textwrap.indent(code, indent))


def test_the_readme_has_code_blocks() -> None:
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("index", range(len(BLOCKS)))
async def test_readme_block_runs(
    index: int, virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    one = await virtual_uno_factory(board_id=1)
    two = await virtual_uno_factory(board_id=2)
    script = tmp_path / f"readme_block_{index}.py"
    script.write_text(script_for(BLOCKS[index], one.port))
    env = {**os.environ, "ARDUINOIO_PORTS": f"{one.port}{os.pathsep}{two.port}"}
    with anyio.fail_after(60):
        result = await anyio.run_process(
            [sys.executable, str(script)], check=False, env=env, cwd=tmp_path
        )
    assert result.returncode == 0, (
        f"README block {index} failed:\n{script.read_text()}\n{result.stderr.decode()}"
    )
