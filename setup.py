"""Build hook: the wheel ships the virtual Uno harness's C sources from ``firmware/sim``.

setuptools has no declarative way to put files from outside the package into it (no
force-include), and the sources must not be copied into the package in git (one copy
to edit).  So ``build_py`` copies ``firmware/sim/*.c`` and ``*.h`` into the built
package as ``arduinoio_async/_data/sim``, where ``arduinoio_async._resources`` looks
for them when installed.  The sdist carries ``firmware/sim`` (MANIFEST.in), so a wheel
built from the sdist gets them the same way.  Everything else is in pyproject.toml.

The package's directory in ``build/lib`` is emptied before each (non-editable) build:
setuptools copies into it and never deletes, so a module removed from git, or a data
file an older configuration picked up, would otherwise ship in every later wheel built
from this clone (``tests/packaging/test_wheel_contents.py`` holds the wheel to an
allow-list).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

#: Source directory (relative to the project root) -> directory inside the built package.
PACKAGE = "arduinoio_async"
HARNESS_SOURCES = Path("firmware", "sim")
HARNESS_TARGET = Path("arduinoio_async", "_data", "sim")


def _harness_files() -> list[Path]:
    return sorted(
        path for path in HARNESS_SOURCES.iterdir() if path.suffix in (".c", ".h") and path.is_file()
    )


class BuildPyWithHarness(build_py):
    """``build_py`` plus the harness sources mapped into the package."""

    def run(self) -> None:
        if not self.editable_mode:
            shutil.rmtree(Path(self.build_lib, PACKAGE), ignore_errors=True)
        super().run()
        if self.editable_mode:
            return  # an editable install runs from the clone, which reads firmware/sim
        files = _harness_files()
        if not any(path.suffix == ".c" for path in files):
            raise RuntimeError(f"no virtual Uno harness sources in {HARNESS_SOURCES}")
        target = Path(self.build_lib, HARNESS_TARGET)
        self.mkpath(str(target))
        names = {path.name for path in files}
        for stale in target.iterdir():  # build/lib outlives a renamed or deleted source
            if stale.name not in names:
                stale.unlink()
        for path in files:
            self.copy_file(str(path), str(target / path.name))

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        outputs: list[str] = super().get_outputs(include_bytecode)
        if not self.editable_mode:
            target = Path(self.build_lib, HARNESS_TARGET)
            outputs += [str(target / path.name) for path in _harness_files()]
        return outputs


setup(cmdclass={"build_py": BuildPyWithHarness})
