"""What a pip user gets: the wheel installed into a fresh venv, used from outside the repo.

The wheel and the venv come from ``conftest.py`` (one of each per session).  Nothing can
come from the clone: the firmware images come from the wheel and the virtual
Uno harness is compiled from the C sources in the wheel (mapped there from firmware/sim by
setup.py, never copied into the package in git) into a fresh per-user cache.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import tarfile
import zipfile
from pathlib import Path

import pytest

from .conftest import Installed, checked

REPO = Path(__file__).resolve().parents[2]
#: Debian's optiboot source (arduino-core-avr), which docs/howto/flashing.md builds.
OPTIBOOT_SOURCE = Path("/usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot/optiboot.c")

pytestmark = [pytest.mark.sim, pytest.mark.timeout(300)]


def test_public_names_import_from_the_installed_wheel(installed: Installed) -> None:
    script = (
        "import arduinoio_async as a\n"
        "from arduinoio_async import Board, BoardManager, VirtualUno, FakeBoard, D2, A0\n"
        "from arduinoio_async import DigitalOutput, Servo, PinState, Sample, SampleStream\n"
        "print(a.__file__)\n"
        "print(a.__version__)\n"
    )
    out = checked(installed.run(installed.exe("python"), "-c", script)).stdout.splitlines()
    assert out[0].startswith(str(installed.venv)), out  # not the clone
    version = (REPO / "arduinoio_async" / "_version.py").read_text()
    assert f'__version__ = "{out[1]}"' in version
    help_text = checked(installed.run(installed.exe("arduinoio"), "flash", "--help")).stdout
    assert "--dry-run" in help_text and "--baud" in help_text


def test_the_wheel_ships_firmware_and_harness_source(installed: Installed) -> None:
    script = (
        "from arduinoio_async import _resources as r\n"
        "for baud in r.FIRMWARE_BAUDS:\n"
        "    print(r.firmware_image(baud, 'hex'), r.firmware_image(baud, 'elf'))\n"
        "print(r.harness_source_dir())\n"
    )
    lines = checked(installed.run(installed.exe("python"), "-c", script)).stdout.splitlines()
    assert len(lines) == 4
    for line in lines[:3]:
        for path in line.split():
            assert path.startswith(str(installed.venv)), line
            assert Path(path).is_file()
    shipped = Path(lines[3])
    assert shipped.is_relative_to(installed.venv), shipped
    assert shipped.parts[-3:] == ("arduinoio_async", "_data", "sim")
    # Every harness source of the clone, byte for byte, and nothing else (setup.py maps them).
    sim = REPO / "firmware" / "sim"
    expected = {path.name: path.read_bytes() for path in (*sim.glob("*.c"), *sim.glob("*.h"))}
    assert {path.name: path.read_bytes() for path in shipped.iterdir()} == expected
    assert "main.c" in expected and "harness.h" in expected


def _start_sim(installed: Installed, *args: str) -> tuple[subprocess.Popen[str], dict[str, object]]:
    process = subprocess.Popen(
        [installed.exe("arduinoio"), "sim", *args],
        cwd=installed.workdir,
        env=installed.env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    line = process.stdout.readline()  # blocks until ready; the harness build comes first
    if not line:
        process.wait(timeout=10)
        assert process.stderr is not None
        pytest.fail(f"arduinoio sim exited: {process.stderr.read()}")
    return process, json.loads(line)


def _stop_sim(process: subprocess.Popen[str]) -> int:
    process.send_signal(signal.SIGINT)
    try:
        return process.wait(timeout=15)
    except subprocess.TimeoutExpired:
        process.kill()
        raise


def _read_id(installed: Installed, port: str) -> str:
    script = (
        "import sys, anyio\n"
        "from arduinoio_async import Board\n"
        "async def main():\n"
        "    async with Board.open(sys.argv[1]) as board:\n"
        "        print(await board.read_id())\n"
        "anyio.run(main)\n"
    )
    return checked(installed.run(installed.exe("python"), "-c", script, port)).stdout.strip()


def _has_steppers(installed: Installed, port: str) -> str:
    """What the board running on ``port`` announces: does its image hold steppers?"""
    script = (
        "import sys, anyio\n"
        "from arduinoio_async import Board, protocol as p\n"
        "async def main():\n"
        "    async with Board.open(sys.argv[1]) as board:\n"
        "        print(bool(board.capabilities.features & p.Feature.STEPPER))\n"
        "anyio.run(main)\n"
    )
    return checked(installed.run(installed.exe("python"), "-c", script, port)).stdout.strip()


def test_arduinoio_sim_from_the_wheel_answers_read_id(installed: Installed) -> None:
    process, info = _start_sim(installed, "--id", "3")
    try:
        assert info["id"] == 3
        assert _read_id(installed, str(info["port"])) == "3"
        # the motor commands work from the wheel without the dev extras
        port = str(info["port"])
        exe = installed.exe("arduinoio")
        pwm = checked(installed.run(exe, "pwm", "--port", port, "D5", "0.4", "--freq", "980"))
        assert pwm.stdout.strip() == "D5: 40.0 % at 976 Hz (Timer0, 256 steps)"
        motor = checked(installed.run(exe, "motor", "--port", port, "D9", "D8", "--speed", "-0.5"))
        assert motor.stdout.strip() == "motor D9 D8: running -0.50"
        cached = list(
            (Path(installed.env["ARDUINOIO_CACHE_DIR"])).glob("virtual-uno-*/virtual-uno")
        )
        assert len(cached) == 1  # built from the wheel's source, keyed by its hash
    finally:
        assert _stop_sim(process) == 0


def _documented_optiboot_build() -> str:
    """The shell block of docs/howto/flashing.md that builds optiboot (after its marker)."""
    page = (REPO / "docs" / "howto" / "flashing.md").read_text()
    after = page.split("<!-- build-optiboot", 1)[1]
    block = after.split("```sh\n", 1)[1].split("```", 1)[0]
    return block


def test_arduinoio_flash_from_the_wheel_through_a_bootloader(installed: Installed) -> None:
    """The docs' path for a pip user: build optiboot as documented, flash a virtual Uno."""
    tools = ("avrdude", "avr-gcc", "avr-objcopy")
    if not OPTIBOOT_SOURCE.is_file() or any(shutil.which(tool) is None for tool in tools):
        if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
            pytest.fail("needs avrdude, gcc-avr and arduino-core-avr")
        pytest.skip("needs avrdude, gcc-avr and arduino-core-avr")
    checked(installed.run("bash", "-e", "-c", _documented_optiboot_build()))
    hex_file = installed.workdir / "optiboot.hex"  # what the docs tell the user to pass
    process, info = _start_sim(installed, "--bootloader", str(hex_file))
    try:
        port = str(info["port"])
        flashed = checked(
            installed.run(installed.exe("arduinoio"), "flash", "--port", port, "--id", "7")
        )
        print(flashed.stdout)
        assert "arduinoio-1000000.hex" in flashed.stdout and "0x0007 stored" in flashed.stdout
        assert _read_id(installed, port) == "7"
        assert _has_steppers(installed, port) == "True"
        # the sensor board's image (docs/firmware-profiles.md): the ID in EEPROM stays
        flashed = checked(
            installed.run(
                installed.exe("arduinoio"), "flash", "--port", port, "--profile", "sensing"
            )
        )
        assert "arduinoio-sensing-1000000.hex" in flashed.stdout
        assert _read_id(installed, port) == "7"
        assert _has_steppers(installed, port) == "False"
    finally:
        assert _stop_sim(process) == 0


def test_sdist_holds_the_whole_project(installed: Installed, tmp_path: Path) -> None:
    checked(installed.run(installed.exe("pip"), "install", "-q", "build", "setuptools>=77"))
    # Without --sdist/--wheel, build makes the sdist and then the wheel FROM the sdist: the
    # harness sources must reach the wheel from the sdist's firmware/sim as well.
    checked(
        installed.run(
            installed.exe("python"),
            "-m",
            "build",
            "--no-isolation",
            "--outdir",
            str(tmp_path),
            str(REPO),
        )
    )
    (sdist,) = tmp_path.glob("arduinoio_async-*.tar.gz")
    with tarfile.open(sdist) as archive:
        names = {name.split("/", 1)[1] for name in archive.getnames() if "/" in name}
    sim_sources = sorted(
        f"firmware/sim/{path.name}"
        for path in (*(REPO / "firmware/sim").glob("*.c"), *(REPO / "firmware/sim").glob("*.h"))
    )
    for required in (
        "LICENSE",
        "CHANGELOG.md",
        "Makefile",
        "setup.py",
        "firmware/Makefile",
        "firmware/src/main.c",
        "firmware/include/aio_protocol.h",
        *sim_sources,
        "firmware/sim/Makefile",
        "firmware/sim/testfw/testfw.c",
        "firmware/bootloader/Makefile",
        "docs/protocol.md",
        "examples/design_card.py",
        "tests/conftest.py",
        "tests/e2e/test_flash.py",
        "arduinoio_async/_data/firmware/arduinoio-115200.hex",
    ):
        assert required in names, required
    assert not any(name.startswith(("firmware/build/", "firmware/sim/build/")) for name in names)
    assert not any(name.startswith("arduinoio_async/_data/sim") for name in names)  # no copy
    assert not any("node_modules" in name for name in names)  # npm's install, not the project
    (wheel,) = tmp_path.glob("arduinoio_async-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        shipped = sorted(
            name.rsplit("/", 1)[1]
            for name in archive.namelist()
            if name.startswith("arduinoio_async/_data/sim/")
        )
    assert shipped == sorted(name.rsplit("/", 1)[1] for name in sim_sources)
