"""The peer's firmware: the prebuilt StandardFirmata for the Uno, fetched with npm.

Nothing of it is committed: ``npm pack`` downloads the pinned ``avrgirl-arduino`` tarball
into ``benchmarks/peers/.cache/`` (untracked), the Uno's ``StandardFirmata.cpp.hex`` is
taken out of it and checked against its SHA-256, and ``avr-objcopy`` turns it into an ELF
the virtual Uno loads (the .hex has one anonymous section; renamed to ``.text``).
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import tarfile
from pathlib import Path

NPM_PACKAGE = "avrgirl-arduino"
NPM_VERSION = "5.0.1"
HEX_MEMBER = "package/junk/hex/uno/StandardFirmata.cpp.hex"
HEX_SHA256 = "6d57ea7cf30e26c9c2f3a01ee37907d2c951f8bc9c27f84dddad12fa9c8b8f36"
#: StandardFirmata 2.4 in that package runs its UART at 57600 baud (UBRR 16, no U2X).
FIRMATA_BAUD = 57600
CACHE = Path(__file__).resolve().parent / ".cache"


class FirmataUnavailable(RuntimeError):
    """npm, the registry or avr-objcopy is missing: the Firmata rows cannot be measured."""


def _run(args: list[str], cwd: Path) -> None:
    try:
        subprocess.run(args, cwd=cwd, check=True, capture_output=True, timeout=300)
    except (OSError, subprocess.SubprocessError) as exc:
        detail = getattr(exc, "stderr", b"") or b""
        message = f"{' '.join(args)} failed: {exc} {detail.decode()[-500:]}"
        raise FirmataUnavailable(message) from exc


def firmata_elf(cache: Path = CACHE) -> Path:
    """The StandardFirmata ELF, fetched and converted on first use."""
    elf = cache / f"StandardFirmata-{NPM_PACKAGE}-{NPM_VERSION}.elf"
    if elf.is_file():
        return elf
    cache.mkdir(parents=True, exist_ok=True)
    tarball = cache / f"{NPM_PACKAGE}-{NPM_VERSION}.tgz"
    if not tarball.is_file():
        if shutil.which("npm") is None:
            raise FirmataUnavailable("npm is not installed (apt-get install npm)")
        _run(["npm", "pack", f"{NPM_PACKAGE}@{NPM_VERSION}", "--silent"], cache)
    with tarfile.open(tarball) as archive:
        member = archive.extractfile(HEX_MEMBER)
        if member is None:
            raise FirmataUnavailable(f"{HEX_MEMBER} missing from {tarball}")
        hex_bytes = member.read()
    digest = hashlib.sha256(hex_bytes).hexdigest()
    if digest != HEX_SHA256:
        raise FirmataUnavailable(f"{HEX_MEMBER}: SHA-256 {digest}, expected {HEX_SHA256}")
    hex_path = cache / "StandardFirmata.cpp.hex"
    hex_path.write_bytes(hex_bytes)
    if shutil.which("avr-objcopy") is None:
        raise FirmataUnavailable("avr-objcopy is not installed (apt-get install binutils-avr)")
    section = ".sec1=.text,contents,alloc,load,readonly,code"
    tmp = elf.with_suffix(".tmp")
    objcopy = ["avr-objcopy", "-I", "ihex", "-O", "elf32-avr", "--rename-section", section]
    _run([*objcopy, str(hex_path), str(tmp)], cache)
    tmp.rename(elf)
    return elf
