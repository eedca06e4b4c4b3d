"""The firmware images in the package are renderings of the sources; the harness is not copied.

The firmware images are like the generated C header: committed so that the wheel works
without an AVR toolchain, and these tests fail when they drift (regenerate with ``make
package-data``).  The virtual Uno harness's C sources have one copy, ``firmware/sim``:
the wheel build maps them into the package (``setup.py``; ``tests/packaging/
test_wheel.py`` checks the wheel), and the harness cache is keyed by all of them.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from arduinoio_async import _resources
from arduinoio_async.protocol.profiles import UNO_PROFILES, image_stem

REPO = Path(__file__).resolve().parents[2]
REGENERATE = "run `make package-data` and commit arduinoio_async/_data"


def test_every_shipped_baud_and_profile_has_both_images() -> None:
    shipped = sorted(path.name for path in _resources.packaged_firmware_dir().iterdir())
    expected = sorted(
        f"{image_stem(baud, profile)}.{kind}"
        for baud in _resources.FIRMWARE_BAUDS
        for profile in UNO_PROFILES
        for kind in ("elf", "hex")
    ) + [
        f"{_resources.board_image_stem(baud, board=board)}.{kind}"
        for baud in _resources.FIRMWARE_BAUDS
        for board in _resources.BOARDS
        if board != "uno"
        for kind in ("elf", "hex")
    ]
    expected.sort()
    assert shipped == expected
    makefile = (REPO / "firmware" / "Makefile").read_text()
    bauds = " ".join(str(baud) for baud in _resources.FIRMWARE_BAUDS)
    assert f"BAUDS = {bauds}\n" in makefile
    assert f"PROFILES ?= {' '.join(UNO_PROFILES)}\n" in makefile


@pytest.mark.skipif(shutil.which("avr-gcc") is None, reason="avr-gcc is not installed")
def test_shipped_firmware_is_a_byte_identical_rebuild_of_firmware_src(tmp_path: Path) -> None:
    subprocess.run(
        ["make", "-s", "-C", str(REPO / "firmware"), f"BUILD={tmp_path}"],
        check=True,
        capture_output=True,
    )
    for shipped in sorted(_resources.packaged_firmware_dir().iterdir()):
        rebuilt = tmp_path / shipped.name
        assert rebuilt.read_bytes() == shipped.read_bytes(), f"{shipped.name} drifted: {REGENERATE}"


def _sim_sources() -> list[Path]:
    sim = REPO / "firmware" / "sim"
    return sorted((*sim.glob("*.c"), *sim.glob("*.h")), key=lambda path: path.name)


@pytest.mark.skipif(not (REPO / ".git").exists(), reason="not a git clone")
def test_no_copy_of_the_harness_sources_is_checked_in() -> None:
    tracked = subprocess.run(
        ["git", "-C", str(REPO), "ls-files", "arduinoio_async/_data"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    assert tracked, "git ls-files answered nothing: not the clone's index"
    assert not [name for name in tracked if not name.startswith("arduinoio_async/_data/firmware/")]


def test_a_clone_builds_the_harness_from_every_file_in_firmware_sim() -> None:
    sources = _resources.harness_sources()
    assert sources == _sim_sources()
    names = {path.name for path in sources}
    assert {"main.c", "pacing.c", "wire.c", "circuit.c", "control.c", "harness.h"} <= names


def test_the_harness_cache_key_covers_every_source(tmp_path: Path) -> None:
    for source in _sim_sources():
        shutil.copy(source, tmp_path / source.name)
    key = _resources.harness_digest(_resources.harness_sources(tmp_path))
    assert key == _resources.harness_digest(_sim_sources())
    header = tmp_path / "wire.h"
    header.write_bytes(header.read_bytes() + b"\n")
    edited = _resources.harness_digest(_resources.harness_sources(tmp_path))
    assert edited != key  # an edited header rebuilds
    (tmp_path / "extra.c").write_bytes(b"")
    added = _resources.harness_digest(_resources.harness_sources(tmp_path))
    assert added != edited  # so does a new (even empty) file
    (tmp_path / "notes.txt").write_text("not a source")
    assert _resources.harness_digest(_resources.harness_sources(tmp_path)) == added


def _as_installed(monkeypatch: pytest.MonkeyPatch, package_data: Path) -> None:
    """Resolve resources as an installed package whose ``_data`` is ``package_data``."""
    monkeypatch.setattr(_resources, "source_tree", lambda: None)
    monkeypatch.setattr(_resources, "_package_data", lambda: package_data)


def _installed_with_sources(monkeypatch: pytest.MonkeyPatch, package_data: Path) -> Path:
    """As installed from a wheel: the sources in ``_data/sim`` (as setup.py maps them)."""
    shipped = package_data / "sim"
    shipped.mkdir(parents=True)
    for source in _sim_sources():
        shutil.copy(source, shipped / source.name)
    _as_installed(monkeypatch, package_data)
    return shipped


def test_installed_package_builds_the_harness_from_its_data_dir(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(_resources.ENV_SIM_BIN, raising=False)
    monkeypatch.setenv(_resources.ENV_CACHE_DIR, str(tmp_path / "cache"))
    shipped = _installed_with_sources(monkeypatch, tmp_path / "_data")
    assert _resources.harness_source_dir() == shipped
    # A cache entry already there for this key is used as it is, without a compiler.
    key = _resources.harness_digest(_resources.harness_sources())
    entry = tmp_path / "cache" / f"virtual-uno-{key}" / "virtual-uno"
    entry.parent.mkdir(parents=True)
    entry.write_text("#!/bin/sh\n")
    entry.chmod(0o755)
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    assert _resources.harness_binary() == entry


def test_missing_harness_sources_say_where_they_were_looked_for(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(_resources.ENV_SIM_BIN, raising=False)
    monkeypatch.setenv(_resources.ENV_CACHE_DIR, str(tmp_path / "cache"))
    _as_installed(monkeypatch, tmp_path / "_data")
    with pytest.raises(_resources.ResourceNotFound, match=r"missing from .*_data/sim"):
        _resources.harness_binary()


def test_resolver_prefers_the_environment_override(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "arduinoio-115200.elf").write_bytes(b"\x7fELF")
    monkeypatch.setenv(_resources.ENV_FIRMWARE_DIR, str(tmp_path))
    assert _resources.firmware_image(115200, "elf") == tmp_path / "arduinoio-115200.elf"
    with pytest.raises(_resources.ResourceNotFound, match="ARDUINOIO_FIRMWARE_DIR"):
        _resources.firmware_image(115200, "hex")


def test_missing_compiler_names_the_packages(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(_resources.ENV_SIM_BIN, raising=False)
    monkeypatch.setenv(_resources.ENV_CACHE_DIR, str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    _installed_with_sources(monkeypatch, tmp_path / "_data")
    with pytest.raises(_resources.ResourceNotFound) as raised:
        _resources.harness_binary()
    message = str(raised.value)
    for package in ("libsimavr-dev", "libelf-dev", "cc"):
        assert package in message
