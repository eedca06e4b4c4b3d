"""What every ``arduinoio`` command shares at its entry point: consoles and exit codes.

One mechanism turns whatever ends a command into one line on stderr and a documented
exit code (``docs/howto/command-line.md``), so no command prints a traceback for
something the user can fix:

====  =====================================================================================
0     success
1     the command failed: a board refused or did not answer, a file or port could not be
      opened (the library's errors and the operating system's, e.g. ``FileNotFoundError``)
2     usage: bad arguments, a missing program (avrdude, the simulator's build tools) or a
      missing optional extra (``pip install 'arduinoio_async[monitor]'``)
130   interrupted (Ctrl-C), as shells report a SIGINT death (128 + 2)
====  =====================================================================================

Anything else is a bug and keeps its traceback.  Exceptions are classified through
anyio's exception groups and through ``__cause__`` chains, because a task group wraps
what its tasks raised, and the network package re-raises a missing Zenoh as an
``ImportError`` whose cause is the ``ModuleNotFoundError``.

The consoles: rich sizes its output to the terminal, and to 80 columns when the output is
not a terminal, which squeezes the benchmark's tables into ellipses in a log.  So when a
stream is not a terminal its console is given a width no table reaches, and lines are not
wrapped: piped output is plain text, one table row per line.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from rich.console import Console
from rich.markup import escape

from ..errors import ArduinoIOError

__all__ = [
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_USAGE",
    "EXTRAS",
    "PIPED_WIDTH",
    "MissingExtra",
    "ToolMissing",
    "classify",
    "make_console",
    "run_command",
]

_log = logging.getLogger(__name__)

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130

#: Console width when the output is not a terminal: wider than any table the CLI prints.
PIPED_WIDTH = 1000

#: Top-level modules of the optional dependencies -> the extra that installs them
#: (pyproject.toml's ``[project.optional-dependencies]``; a test checks they agree).
EXTRAS = {
    "starlette": "monitor",
    "uvicorn": "monitor",
    "websockets": "monitor",
    "zenoh": "network",
    "matplotlib": "plot",
    "rosbags": "ros2",
    "yaml": "ros2",
}


class ToolMissing(Exception):
    """A program or file the command needs is not there; the message says what to do."""


class MissingExtra(Exception):
    """An optional dependency is not installed; the message names the extra to install."""

    def __init__(self, module: str, extra: str) -> None:
        super().__init__(
            f"{module} is not installed, this command needs its extra: "
            f"pip install 'arduinoio_async[{extra}]'"
        )
        self.module = module
        self.extra = extra


def make_console(*, stderr: bool = False) -> Console:
    """A console for the CLI's output: the terminal's width, or unbounded when piped."""
    console = Console(stderr=stderr)
    if not console.is_terminal:
        console = Console(stderr=stderr, width=PIPED_WIDTH, soft_wrap=True)
    return console


def _leaves(exc: BaseException) -> list[BaseException]:
    if isinstance(exc, BaseExceptionGroup):
        return [leaf for inner in exc.exceptions for leaf in _leaves(inner)]
    return [exc]


def _missing_extra(exc: BaseException) -> MissingExtra | None:
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, ModuleNotFoundError) and seen.name:
            top = seen.name.split(".", 1)[0]
            if top in EXTRAS:
                return MissingExtra(top, EXTRAS[top])
        seen = seen.__cause__
    return None


def classify(exc: BaseException) -> tuple[int, str | None] | None:
    """The exit code and the one line for ``exc``, or None for a bug (keep the traceback)."""
    leaves = _leaves(exc)
    if any(isinstance(leaf, KeyboardInterrupt) for leaf in leaves):
        return EXIT_INTERRUPTED, "interrupted"
    for leaf in leaves:
        if isinstance(leaf, SystemExit):
            return None  # argparse's usage errors and --help: their own output and code
    for leaf in leaves:
        missing = _missing_extra(leaf)
        if missing is not None:
            return EXIT_USAGE, str(missing)
        if isinstance(leaf, ToolMissing | MissingExtra):
            return EXIT_USAGE, str(leaf)
    for leaf in leaves:
        if isinstance(leaf, ArduinoIOError | OSError):
            return EXIT_FAILED, str(leaf)
    return None


def run_command(command: Callable[[], int], errors: Console) -> int:
    """Run ``command`` (a whole CLI command) and map how it ended to an exit code."""
    try:
        return command()
    except BaseException as exc:
        verdict = classify(exc)
        if verdict is None:
            raise
        code, line = verdict
        _log.debug("command ended with exit code %d", code, exc_info=True)
        if line is not None:
            errors.print(f"[red]error:[/] {escape(line)}", highlight=False, soft_wrap=True)
        return code
