"""Every ```python block of the documentation site runs, so no page shows code that fails.

How a block is run, and how a block that cannot run says so, is the docstring of
:mod:`tests.docs.snippets`.  README.md's blocks have their own test
(``tests/packaging/test_readme.py``).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import anyio
import pytest

from arduinoio_async.protocol.profiles import DEFAULT_PROFILE, UNO_PROFILES
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .snippets import DOCS, REPO, Block, Kind, blocks, script_for

pytestmark = pytest.mark.sim

BLOCKS = blocks()
DEADLINE = 60.0
EXAMPLE_TESTS = REPO / "tests" / "examples" / "test_examples.py"


def test_the_pages_have_code_blocks() -> None:
    pages = {block.page for block in BLOCKS}
    assert len(BLOCKS) >= 30
    assert DOCS / "concepts" / "streams.md" in pages
    assert DOCS / "howto" / "testing.md" in pages


def test_every_skip_marker_is_well_formed_and_says_why() -> None:
    for block in BLOCKS:
        if block.marker is not None and block.profile is None:
            assert block.skip, f"{block.name}: write <!-- docs-test: skip: REASON -->"
            assert len(block.skip.split()) >= 4, f"{block.name}: say why it cannot run"
        if block.profile is not None:
            assert block.profile in UNO_PROFILES, f"{block.name}: no image {block.profile!r}"


async def play_the_world(uno: VirtualUno) -> None:
    """A button on D3 pressed and released every 50 ms, A0 sweeping 0-5 V."""
    step = 0
    while True:
        await uno.drive("D3", step % 2 == 0)
        await uno.set_analog(0, (step * 250) % 5250)
        step += 1
        await anyio.sleep(0.05)


async def run(command: list[str], cwd: Path, env: dict[str, str]) -> tuple[int | None, str]:
    """The command's exit code (None: still running at the deadline, then killed) and all
    it printed, stdout and stderr interleaved as a terminal would show them."""
    log = cwd / "output.txt"
    with log.open("wb") as out:
        process = await anyio.open_process(command, stdout=out, stderr=out, cwd=cwd, env=env)
        returncode: int | None = None
        try:
            with anyio.move_on_after(DEADLINE):
                returncode = await process.wait()
        finally:
            if returncode is None:
                process.kill()
                await process.wait()
    output = log.read_bytes().decode(errors="replace")
    if returncode is None:
        output += f"\n[still running after {DEADLINE:.0f} s: killed]"
    return returncode, output


def check_example_include(block: Block) -> None:
    tested = EXAMPLE_TESTS.read_text()
    for path in block.includes:
        included = REPO / path
        assert included.is_file(), f"{block.name} includes {path}, which does not exist"
        assert included.parent == REPO / "examples", f"{block.name}: {path} is no example"
        assert re.search(rf"^(async )?def test_{included.stem}(_\w+)?\(", tested, re.MULTILINE), (
            f"{block.name} shows {path}, which tests/examples/test_examples.py does not run"
        )


@pytest.mark.parametrize("block", BLOCKS, ids=[block.name for block in BLOCKS])
async def test_docs_block_runs(
    block: Block, virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    if block.skip:
        pytest.skip(f"{block.name}: {block.skip}")
    if block.kind is Kind.INCLUDE:
        check_example_include(block)
        return
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    if block.kind is Kind.TESTS:
        script = tmp_path / "test_docs_block.py"
        script.write_text(block.code)
        command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
        command += ["-o", "asyncio_mode=auto", str(script)]
        returncode, output = await run(command, tmp_path, env)
        ran = re.search(r"\b\d+ passed\b", output) and "skipped" not in output
        assert returncode == 0 and ran, f"{block.name} failed:\n{block.code}\n{output}"
        return
    image = block.profile or DEFAULT_PROFILE
    unos = [await virtual_uno_factory(board_id=1, profile=image)]
    if "BoardManager(" in block.code:
        unos.append(await virtual_uno_factory(board_id=2, profile=image))
    env["ARDUINOIO_PORTS"] = os.pathsep.join(uno.port for uno in unos)
    script = tmp_path / "docs_block.py"
    script.write_text(script_for(block, unos[0].port))
    async with anyio.create_task_group() as tg:
        tg.start_soon(play_the_world, unos[0])
        returncode, output = await run([sys.executable, str(script)], tmp_path, env)
        tg.cancel_scope.cancel()
    assert returncode == 0, (
        f"{block.name} ({block.kind.value}) failed:\n{script.read_text()}\n{output}"
    )
