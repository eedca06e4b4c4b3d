"""The CLI's one mechanism for how a command ends (``arduinoio_async.cli._entry``).

The end-to-end cases (Ctrl-C during ``bench``, a missing avrdude, missing extras in a
bare venv) are in ``tests/e2e/test_cli_entry.py`` and ``tests/packaging/test_bare_venv.py``;
these check the classification through the shapes an exception reaches the entry point
in: bare, inside anyio's exception groups, and as the cause of another exception.
"""

from __future__ import annotations

import io
import tomllib
from pathlib import Path

import pytest
from rich.console import Console

from arduinoio_async.cli import _entry
from arduinoio_async.errors import ArduinoIOError

REPO = Path(__file__).resolve().parents[1]


def _run(exc: BaseException) -> tuple[int, str]:
    out = io.StringIO()

    def command() -> int:
        raise exc

    code = _entry.run_command(command, Console(file=out, width=80))
    return code, out.getvalue()


def _missing(module: str) -> ModuleNotFoundError:
    return ModuleNotFoundError(f"No module named '{module}'", name=module)


@pytest.mark.parametrize(
    ("exc", "code", "line"),
    [
        (KeyboardInterrupt(), 130, "error: interrupted\n"),
        (BaseExceptionGroup("tasks", [KeyboardInterrupt()]), 130, "error: interrupted\n"),
        (ArduinoIOError("board 0x0007 did not answer"), 1, "error: board 0x0007 did not answer\n"),
        (
            ExceptionGroup("tasks", [ExceptionGroup("inner", [ArduinoIOError("refused")])]),
            1,
            "error: refused\n",
        ),
        (
            FileNotFoundError(2, "No such file or directory", "/nope.hex"),
            1,
            "error: [Errno 2] No such file or directory: '/nope.hex'\n",
        ),
        (_entry.ToolMissing("avrdude is not installed"), 2, "error: avrdude is not installed\n"),
    ],
)
def test_an_error_the_user_can_fix_is_one_line_and_a_code(
    exc: BaseException, code: int, line: str
) -> None:
    assert _run(exc) == (code, line)


def _caused_by(cause: BaseException) -> ImportError:
    exc = ImportError("boards on the network need Zenoh")  # as arduinoio_async.network raises
    exc.__cause__ = cause
    return exc


@pytest.mark.parametrize(
    ("exc", "module", "extra"),
    [
        (_missing("uvicorn"), "uvicorn", "monitor"),
        (_caused_by(_missing("zenoh.ext")), "zenoh", "network"),
        (ExceptionGroup("tasks", [_caused_by(_missing("zenoh"))]), "zenoh", "network"),
    ],
)
def test_a_missing_extra_is_named_also_behind_a_cause_and_a_group(
    exc: BaseException, module: str, extra: str
) -> None:
    code, text = _run(exc)
    assert code == 2
    assert text.splitlines() == [
        f"error: {module} is not installed, this command needs its extra: "
        f"pip install 'arduinoio_async[{extra}]'"
    ]


def test_a_bug_keeps_its_traceback() -> None:
    with pytest.raises(ZeroDivisionError):
        _run(ZeroDivisionError("a bug"))
    with pytest.raises(ModuleNotFoundError):  # not an optional dependency: a broken install
        _run(_missing("anyio"))
    with pytest.raises(SystemExit):  # argparse: its own message and code 2
        _run(SystemExit(2))


def test_every_extra_named_is_an_extra_that_installs_that_module() -> None:
    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    for module, extra in _entry.EXTRAS.items():
        requirements = " ".join(extras[extra])
        assert module in requirements.replace("eclipse-zenoh", "zenoh"), (module, extra)


def test_a_piped_console_is_not_squeezed_to_80_columns() -> None:
    assert not _entry.make_console().is_terminal  # pytest captures stdout
    assert _entry.make_console().width == _entry.PIPED_WIDTH
