"""The wheel holds exactly the runtime files: an allow-list, so a stray file fails the test.

Anything under the package directory can slip into a wheel (setuptools' namespace-package
discovery and ``include-package-data`` take whole trees): ``make setup`` leaves npm's
``monitor/npm/node_modules`` there, and ``build/lib`` keeps a module that was deleted from
git.  The allow-list is: the package's Python modules as git tracks them, the data the code
reads at run time (named one by one below), and the dist-info.  A new runtime file is
added here on purpose, with the code that reads it.
"""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

from arduinoio_async import _resources
from arduinoio_async.protocol.profiles import UNO_PROFILES, image_stem

from .conftest import REPO

#: Runtime data of the package, by path inside the wheel; every other non-.py file fails.
DATA = {
    "arduinoio_async/py.typed",
    *(
        f"arduinoio_async/_data/firmware/{image_stem(baud, profile)}.{kind}"
        for baud in _resources.FIRMWARE_BAUDS
        for profile in UNO_PROFILES
        for kind in ("hex", "elf")
    ),
    *(
        f"arduinoio_async/_data/firmware/{_resources.board_image_stem(baud, board=board)}.{kind}"
        for baud in _resources.FIRMWARE_BAUDS
        for board in _resources.BOARDS
        if board != "uno"
        for kind in ("hex", "elf")
    ),
    # the virtual Uno harness, compiled on first use (setup.py maps firmware/sim here)
    *(
        f"arduinoio_async/_data/sim/{path.name}"
        for path in sorted((REPO / "firmware" / "sim").iterdir())
        if path.suffix in (".c", ".h")
    ),
    # the monitor's page and the uPlot build `make monitor-assets` vendors (MIT, with licence)
    "arduinoio_async/monitor/static/index.html",
    "arduinoio_async/monitor/static/monitor.css",
    "arduinoio_async/monitor/static/monitor.js",
    "arduinoio_async/monitor/static/vendor/uPlot.iife.min.js",
    "arduinoio_async/monitor/static/vendor/uPlot.min.css",
    "arduinoio_async/monitor/static/vendor/uPlot.LICENSE",
}

DIST_INFO = {"METADATA", "WHEEL", "RECORD", "entry_points.txt", "top_level.txt", "licenses/LICENSE"}


def _tracked_modules() -> set[str]:
    listed = subprocess.run(
        ["git", "-C", str(REPO), "ls-files", "arduinoio_async/*.py", "arduinoio_async/**/*.py"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return set(listed)


def test_the_wheel_holds_exactly_the_runtime_files(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as archive:
        names = {name for name in archive.namelist() if not name.endswith("/")}
    dist_info = {name for name in names if name.split("/", 1)[0].endswith(".dist-info")}
    assert {name.split("/", 1)[1] for name in dist_info} == DIST_INFO
    package = names - dist_info
    modules = {name for name in package if name.endswith(".py")}
    assert modules == _tracked_modules(), "modules in the wheel that git does not track, or gone"
    unexpected = sorted(package - modules - DATA)
    assert not unexpected, f"{len(unexpected)} files not on the allow-list: {unexpected}"
    assert sorted(DATA - package) == []  # and every runtime file is there
