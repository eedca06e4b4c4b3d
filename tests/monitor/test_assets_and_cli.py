"""The browser files the package ships, and the command line's refusals.

uPlot is installed by npm (``make monitor-assets``) from the pinned lock file into the
package's static dir; it is never committed.  These checks fail when the installed file is
missing or is not the one the lock file pins.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rich.console import Console

from arduinoio_async.cli import main

monitor_app = pytest.importorskip("arduinoio_async.monitor._app")

MONITOR_DIR = Path(monitor_app.__file__).parent
NPM_DIR = MONITOR_DIR / "npm"
PINNED = "1.6.32"


def test_uplot_is_pinned_and_installed_from_the_lock_file() -> None:
    manifest = json.loads((NPM_DIR / "package.json").read_text())
    lock = json.loads((NPM_DIR / "package-lock.json").read_text())
    assert manifest["dependencies"] == {"uplot": PINNED}
    assert lock["packages"]["node_modules/uplot"]["version"] == PINNED
    assert lock["packages"]["node_modules/uplot"]["integrity"].startswith("sha512-")
    assert monitor_app.missing_assets() == [], "run `make monitor-assets` (needs npm)"
    installed = NPM_DIR / "node_modules" / "uplot"
    if not installed.is_dir():
        pytest.skip("no npm tree here (an installed wheel): the files were checked at build")
    assert json.loads((installed / "package.json").read_text())["version"] == PINNED
    for name in monitor_app.VENDOR_FILES:
        shipped = (MONITOR_DIR / "static" / name).read_bytes()
        assert shipped == (installed / "dist" / Path(name).name).read_bytes(), name


def test_the_page_loads_nothing_from_outside() -> None:
    page = (MONITOR_DIR / "static" / "index.html").read_text()
    script = (MONITOR_DIR / "static" / "monitor.js").read_text()
    for text in (page, script):
        assert "http://" not in text and "https://" not in text and "//cdn" not in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--port", "loop://", "--http", "nowhere"], "HOST:PORT"),
        (["--remote"], "--remote needs --id"),
        (["--remote", "--id", "7", "--port", "loop://"], "name a board twice"),
        (["--port", "loop://", "--id", "7"], "give one of them"),
    ],
)
def test_monitor_command_refusals(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["monitor", *argv], console=Console(width=200)) == 1
    assert message in capsys.readouterr().err
