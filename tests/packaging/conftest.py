"""The wheel, built once per test session, and a fresh venv that holds only it (and its deps).

Building the wheel, creating the venv and installing take ~10 s, so every packaging
module shares one of each (session scope).  pip installs the dependencies from its
configured index or cache, so no network is needed where the dev environment could be
installed.  The venv has none of the extras and not pytest: it is what ``pip install
arduinoio_async`` gives a new user.  A test that needs more installs it into a venv of
its own (see ``Installed.with_packages``), never into this shared one.  Every command runs
with a temporary directory as its working directory and without the repo's overrides
(``ARDUINOIO_*``, ``PYTHON*``, ``VIRTUAL_ENV``), so nothing can come from the clone.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@dataclass
class Installed:
    """A fresh venv with the wheel installed, and where to run things from."""

    venv: Path
    workdir: Path
    env: dict[str, str]
    wheel: Path

    def exe(self, name: str) -> str:
        return str(self.venv / "bin" / name)

    def run(self, *argv: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            argv,
            cwd=self.workdir,
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )


def checked(result: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    """``result`` when its command succeeded; otherwise a failure showing its output."""
    assert result.returncode == 0, f"{result.args}:\n{result.stdout}\n{result.stderr}"
    return result


def make_venv(root: Path, wheel: Path, *requirements: str) -> Installed:
    """A venv under ``root`` with ``wheel`` (no extras) and ``requirements`` installed."""
    venv = root / "venv"
    checked(
        subprocess.run(
            [sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True, check=False
        )
    )
    workdir = root / "work"
    workdir.mkdir()
    env = {
        key: value
        for key, value in os.environ.items()
        if not key.startswith(("ARDUINOIO_", "PYTHON", "VIRTUAL_ENV"))
    }
    env["ARDUINOIO_CACHE_DIR"] = str(root / "cache")  # the harness gets built afresh
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    box = Installed(venv, workdir, env, wheel)
    checked(box.run(box.exe("pip"), "install", "-q", str(wheel), *requirements, timeout=300))
    return box


@pytest.fixture(scope="session")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel ``pip wheel`` builds from this clone (as it is, build/ and all)."""
    dist = tmp_path_factory.mktemp("dist")
    checked(
        subprocess.run(
            [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(REPO)],
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    )
    (built,) = dist.glob("arduinoio_async-*.whl")
    return built


@pytest.fixture(scope="session")
def installed(tmp_path_factory: pytest.TempPathFactory, wheel: Path) -> Iterator[Installed]:
    """A fresh venv with only the wheel and its dependencies: no extras, no pytest."""
    yield make_venv(tmp_path_factory.mktemp("wheel"), wheel)
