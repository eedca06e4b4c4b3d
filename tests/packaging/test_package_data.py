"""The firmware images and harness source in the package are renderings of the sources.

Like the generated C header: they are committed so that the wheel works without an AVR
toolchain, and these tests fail when they drift.  Regenerate with ``make package-data``.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from arduinoio_async import _resources

REPO = Path(__file__).resolve().parents[2]
REGENERATE = "run `make package-data` and commit arduinoio_async/_data"


def test_every_shipped_baud_has_both_images() -> None:
    shipped = sorted(path.name for path in _resources.packaged_firmware_dir().iterdir())
    expected = sorted(
        f"arduinoio-{baud}.{kind}" for baud in _resources.FIRMWARE_BAUDS for kind in ("elf", "hex")
    )
    assert shipped == expected
    makefile = (REPO / "firmware" / "Makefile").read_text()
    bauds = " ".join(str(baud) for baud in _resources.FIRMWARE_BAUDS)
    assert f"BAUDS = {bauds}\n" in makefile


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


def test_shipped_harness_source_is_the_clone_s() -> None:
    shipped = _resources.packaged_firmware_dir().parent / "sim" / "virtual_uno.c"
    source = REPO / "firmware" / "sim" / "virtual_uno.c"
    assert shipped.read_bytes() == source.read_bytes(), f"virtual_uno.c drifted: {REGENERATE}"


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
    monkeypatch.setattr(_resources, "source_tree", lambda: None)  # as when installed
    with pytest.raises(_resources.ResourceNotFound) as raised:
        _resources.harness_binary()
    message = str(raised.value)
    for package in ("libsimavr-dev", "libelf-dev", "cc"):
        assert package in message
