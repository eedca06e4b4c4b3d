"""The blocking API's old import path, ``arduinoio_async.sync``, still works and warns."""

from __future__ import annotations

import subprocess
import sys


def run_fresh(script: str) -> str:
    """``script``'s output in a fresh interpreter (a module warns on its first import only,
    and another test of this process may have imported it already)."""
    return subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True
    ).stdout


def test_the_old_path_warns_and_gives_the_same_objects() -> None:
    script = (
        "import warnings\n"
        "warnings.simplefilter('error', DeprecationWarning)\n"
        "try:\n"
        "    import arduinoio_async.sync\n"
        "except DeprecationWarning as w:\n"
        "    print('warned:', w)\n"
        "warnings.simplefilter('ignore')\n"
        "import arduinoio_async.sync as old, arduinoio_async.blocking as new\n"
        "assert old.connect is new.connect and old.open_board is new.open_board\n"
        "assert old.BlockingBoard is new.BlockingBoard and old.__all__ == new.__all__\n"
        "print('same objects')\n"
    )
    out = run_fresh(script)
    assert "warned: arduinoio_async.sync is deprecated: import arduinoio_async.blocking" in out
    assert "same objects" in out


def test_the_new_path_does_not_warn() -> None:
    script = (
        "import warnings\n"
        "warnings.simplefilter('error', DeprecationWarning)\n"
        "import arduinoio_async.blocking\n"
        "print('quiet')\n"
    )
    assert run_fresh(script).strip() == "quiet"
