"""The ```python blocks of the documentation site, and how each one is run.

The conventions (also for whoever adds a block to a page):

* A **complete program** (it calls ``anyio.run``) and a **blocking script** (no
  ``await``/``async`` anywhere: ``arduinoio_async.blocking``) run as they are, so they must
  import every name they use.
* A **test module** (it defines ``test_...`` functions) runs under pytest, with
  ``asyncio_mode=auto`` as testing.md tells its readers; it must import what it uses too.
* Any other block is a **fragment** of async code.  It runs inside ``async def main()``
  after ``from arduinoio_async import *``, with ``board`` open on the virtual Uno that
  stands for ``/dev/ttyACM0`` unless the fragment opens its own board(s)
  (``Board.open(``, ``BoardManager(``, ...).  ``control(...)`` and ``await
  run_robot(board)`` stand for the reader's own code and do nothing.
* A block that only includes a file (``--8<-- "examples/NAME.py"``) is the example
  program itself, which ``tests/examples/test_examples.py`` runs; the test checks that
  it does.
* A block that cannot run here (another library's API, a second computer) carries the
  marker ``<!-- docs-test: skip: REASON -->`` on the line before its fence.  The marker is
  an HTML comment, invisible on the site; its reason is the test's skip reason, so every
  skipped block is listed, with why, in the test report (``pytest -rs``).
* A block that needs another firmware image than the default (docs/firmware-profiles.md)
  says which on the line before its fence: ``<!-- docs-test: profile: sensing -->``; its
  virtual Uno runs that image, as the reader's board would after ``arduinoio flash
  --profile sensing``.

Every block runs in its own Python process, as a reader's script would, with
``/dev/ttyACM0`` replaced by the virtual Uno's port and ``127.0.0.1:8000`` (the monitor
example's address) by ``127.0.0.1:0`` (a free port).  A loop over events must end by
itself (``break`` on a condition, as a real program would): while the block runs, the
test plays the world on board 0x0001, a button on D3 pressed and released every 50 ms
and a voltage on A0 sweeping 0-5 V.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DOCS = REPO / "docs"

FENCE = re.compile(
    r"^(?P<indent>[ \t]*)```python[^\n]*\n(?P<code>.*?)^(?P=indent)```[ \t]*$",
    re.DOTALL | re.MULTILINE,
)
SKIP = re.compile(r"^\s*<!--\s*docs-test:\s*skip\s*:\s*(?P<reason>.*?)\s*-->\s*$")
PROFILE = re.compile(r"^\s*<!--\s*docs-test:\s*profile\s*:\s*(?P<name>[a-z]+)\s*-->\s*$")
MARKER = re.compile(r"<!--\s*docs-test")
INCLUDE = re.compile(r'^--8<--\s+"(?P<path>[^"]+)"$')
#: What a fragment calls to open its own board; without one it gets ``board``.
OPENS_A_BOARD = ("Board.open(", "Board.connect(", "BoardManager(", "VirtualUno(")


class Kind(Enum):
    PROGRAM = "program"
    SCRIPT = "blocking script"
    TESTS = "test module"
    FRAGMENT = "fragment"
    INCLUDE = "example include"


@dataclass(frozen=True)
class Block:
    """One ```python block: where it is, its code, and the skip reason if it has one."""

    page: Path
    line: int
    code: str
    skip: str | None
    marker: str | None  # the raw marker line, for checking its form
    #: The firmware image its virtual Uno runs (None: the default).
    profile: str | None = None

    @property
    def name(self) -> str:
        return f"{self.page.relative_to(DOCS)}:{self.line}"

    @property
    def kind(self) -> Kind:
        lines = [line for line in self.code.splitlines() if line.strip()]
        if lines and all(INCLUDE.match(line.strip()) for line in lines):
            return Kind.INCLUDE
        if re.search(r"^(async )?def test_", self.code, re.MULTILINE):
            return Kind.TESTS
        if "anyio.run(" in self.code:
            return Kind.PROGRAM
        if not re.search(r"\b(await|async)\b", self.code):
            return Kind.SCRIPT
        return Kind.FRAGMENT

    @property
    def includes(self) -> list[str]:
        return [m["path"] for m in map(INCLUDE.match, self.code.splitlines()) if m]


def blocks() -> list[Block]:
    """Every ```python block of every page under docs/, in page order."""
    found = []
    for page in sorted(DOCS.rglob("*.md")):
        text = page.read_text()
        for match in FENCE.finditer(text):
            before = text[: match.start()].rstrip("\n").splitlines()
            previous = before[-1] if before else ""
            skip = SKIP.match(previous)
            profile = PROFILE.match(previous)
            found.append(
                Block(
                    page=page,
                    line=text.count("\n", 0, match.start()) + 1,
                    code=textwrap.dedent(match["code"]),
                    skip=skip["reason"] if skip else None,
                    marker=previous if MARKER.search(previous) else None,
                    profile=profile["name"] if profile else None,
                )
            )
    return found


FRAGMENT = """\
import anyio
from arduinoio_async import *


def control(*values: object) -> None:
    pass


async def run_robot(board: object) -> None:
    pass


async def main() -> None:
{open_board}{body}


anyio.run(main)
"""


def script_for(block: Block, port: str) -> str:
    """The Python file that runs ``block`` against the board on ``port``."""
    code = block.code.replace("/dev/ttyACM0", port).replace("127.0.0.1:8000", "127.0.0.1:0")
    if block.kind is not Kind.FRAGMENT:
        return code
    opens_board = any(opener in code for opener in OPENS_A_BOARD)
    indent = "    " if opens_board else "        "
    open_board = "" if opens_board else f"    async with Board.open({port!r}) as board:\n"
    return FRAGMENT.format(open_board=open_board, body=textwrap.indent(code, indent))
