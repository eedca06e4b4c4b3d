"""Where the firmware images and the virtual Uno harness are, in a clone and when installed.

The same code runs from a git clone (``make firmware sim`` builds into ``firmware/build``
and ``firmware/sim/build``) and from a wheel in a venv that has no clone at all.  Every
other module asks this one, so no path is computed from ``__file__`` anywhere else.

Firmware (``arduinoio-<baud>.hex`` for flashing, ``.elf`` for the virtual Uno), first hit:

1. ``$ARDUINOIO_FIRMWARE_DIR``;
2. in a clone: ``firmware/build`` when it holds that image (what ``make firmware`` built);
3. the images shipped in the package (``arduinoio_async/_data/firmware``).  They are
   generated artifacts (``make package-data``), and a test rebuilds them from
   ``firmware/src`` and checks they are byte-identical, like the generated C header.

Virtual Uno harness (``virtual-uno``), first hit:

1. ``$ARDUINOIO_SIM_BIN``;
2. in a clone: ``firmware/sim/build/virtual-uno``;
3. built on first use from the C sources (``firmware/sim/*.c`` and ``*.h``) into a
   per-user cache, ``$ARDUINOIO_CACHE_DIR`` or ``$XDG_CACHE_HOME/arduinoio_async``
   (default ``~/.cache/arduinoio_async``), in a directory named after the hash of all of
   them so that an upgrade (or an edited header) rebuilds.  simavr is GPL-3, so the
   package ships source, never a linked binary; building needs ``cc``,
   ``libsimavr-dev`` and ``libelf-dev``.

The harness sources are not copied into the package in git: the build maps
``firmware/sim/*.c|*.h`` into the wheel as ``arduinoio_async/_data/sim`` (``setup.py``),
and the sdist carries ``firmware/sim`` itself.  So a clone reads ``firmware/sim`` and an
installed package reads ``_data/sim``; there is one copy to edit.
"""

from __future__ import annotations

import fcntl
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from importlib import resources
from pathlib import Path
from typing import Final

from .errors import ArduinoIOError
from .protocol import FIRMWARE_BAUDS  # the Makefile's BAUDS: built and shipped
from .protocol.profiles import DEFAULT_PROFILE, UNO_PROFILES, image_stem

__all__ = [
    "ENV_CACHE_DIR",
    "ENV_FIRMWARE_DIR",
    "ENV_SIM_BIN",
    "FIRMWARE_BAUDS",
    "HARNESS_PACKAGES",
    "ResourceNotFound",
    "cache_dir",
    "firmware_image",
    "harness_binary",
    "harness_digest",
    "harness_source_dir",
    "harness_sources",
    "packaged_firmware_dir",
    "source_tree",
]


_log = logging.getLogger(__name__)

ENV_FIRMWARE_DIR = "ARDUINOIO_FIRMWARE_DIR"
ENV_SIM_BIN = "ARDUINOIO_SIM_BIN"
ENV_CACHE_DIR = "ARDUINOIO_CACHE_DIR"


#: Debian/Ubuntu packages the harness build needs (compiler, simavr headers and library).
HARNESS_PACKAGES = ("gcc", "libsimavr-dev", "libelf-dev")

_HARNESS_CFLAGS = ("-O2", "-I/usr/include/simavr", "-I/usr/include/simavr/parts")
_HARNESS_LIBS = ("-lsimavr", "-lsimavrparts", "-lelf", "-lpthread", "-lm")


class ResourceNotFound(ArduinoIOError):
    """A firmware image or the simulator harness is not there; the message says what to do."""


def _package_data() -> Path:
    return Path(str(resources.files("arduinoio_async"))) / "_data"


def packaged_firmware_dir() -> Path:
    """The directory of the firmware images shipped inside the package."""
    return _package_data() / "firmware"


def source_tree() -> Path | None:
    """The root of the git clone this package runs from, or None when it is installed."""
    root = Path(str(resources.files("arduinoio_async"))).resolve().parent
    if (root / "firmware" / "src").is_dir() and (root / "pyproject.toml").is_file():
        return root
    return None


#: Boards with a firmware image of their own (``board=``): the Uno's profiles, or the
#: Mega 2560's one image with every class (``arduinoio-mega2560-<baud>``, make -C firmware mega).
BOARDS: Final = ("uno", "mega2560")


def board_image_stem(baud: int, profile: str = DEFAULT_PROFILE, board: str = "uno") -> str:
    """The image file's name without extension for ``board`` (ValueError for an unknown
    board, or a profile other than the default for a board with one image)."""
    if board not in BOARDS:
        raise ValueError(f"no firmware for board {board!r} (boards: {', '.join(BOARDS)})")
    if board == "uno":
        return image_stem(baud, profile)
    if profile != DEFAULT_PROFILE:
        raise ValueError(f"the {board} image has every class: it has no profile {profile!r}")
    return f"arduinoio-{board}-{baud}"


def firmware_image(
    baud: int, kind: str = "hex", profile: str = DEFAULT_PROFILE, board: str = "uno"
) -> Path:
    """The image of build ``profile`` for ``baud`` (kind ``hex`` or ``elf``), searched as
    the module says: ``arduinoio-<baud>.<kind>`` for the standard profile,
    ``arduinoio-<profile>-<baud>.<kind>`` for the others (protocol/profiles.py);
    ``board="mega2560"``: ``arduinoio-mega2560-<baud>.<kind>`` (one image, no profiles)."""
    if kind not in ("hex", "elf"):
        raise ValueError(f"firmware image kind is 'hex' or 'elf', not {kind!r}")
    name = f"{board_image_stem(baud, profile, board)}.{kind}"
    env = os.environ.get(ENV_FIRMWARE_DIR)
    if env:
        path = Path(env) / name
        if not path.is_file():
            raise ResourceNotFound(f"{path} does not exist (${ENV_FIRMWARE_DIR} is set to {env})")
        return path
    candidates = []
    tree = source_tree()
    if tree is not None:
        candidates.append(tree / "firmware" / "build" / name)
    candidates.append(packaged_firmware_dir() / name)
    for path in candidates:
        if path.is_file():
            return path
    shipped = ", ".join(str(b) for b in FIRMWARE_BAUDS)
    raise ResourceNotFound(
        f"no firmware image {name} (looked in {', '.join(str(c.parent) for c in candidates)}); "
        f"images ship for {shipped} baud in the profiles {', '.join(UNO_PROFILES)}, "
        f"or build others with `make -C firmware BAUD={baud}` "
        f"and point ${ENV_FIRMWARE_DIR} at firmware/build"
    )


def harness_source_dir() -> Path:
    """The harness's C sources: the clone's ``firmware/sim``, else the package's ``_data/sim``."""
    tree = source_tree()
    if tree is not None:
        return tree / "firmware" / "sim"
    return _package_data() / "sim"


def harness_sources(directory: Path | None = None) -> list[Path]:
    """The ``*.c`` and ``*.h`` files the harness is built from, sorted by name."""
    directory = harness_source_dir() if directory is None else directory
    if not directory.is_dir():
        return []
    return sorted(
        (path for path in directory.iterdir() if path.suffix in (".c", ".h") and path.is_file()),
        key=lambda path: path.name,
    )


def harness_digest(sources: list[Path]) -> str:
    """A short hash of every source's name and bytes: the cache entry's key.

    Names count too, so renaming or adding a file rebuilds even if the bytes stay.
    """
    digest = hashlib.sha256()
    for source in sources:
        content = source.read_bytes()
        digest.update(f"{source.name}\0{len(content)}\0".encode())
        digest.update(content)
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """The per-user cache the harness is built into."""
    env = os.environ.get(ENV_CACHE_DIR)
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg else Path.home() / ".cache"
    return base / "arduinoio_async"


def harness_binary() -> Path:
    """The ``virtual-uno`` executable, built into the cache on first use (blocking)."""
    env = os.environ.get(ENV_SIM_BIN)
    if env:
        path = Path(env)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise ResourceNotFound(f"{path} is not an executable (${ENV_SIM_BIN} is set to it)")
        return path
    tree = source_tree()
    if tree is not None:
        built = tree / "firmware" / "sim" / "build" / "virtual-uno"
        if built.is_file() and os.access(built, os.X_OK):
            return built
    return _build_cached_harness(harness_source_dir())


def _install_hint() -> str:
    return (
        "it needs a C compiler (cc), libsimavr-dev and libelf-dev: "
        f"sudo apt-get install {' '.join(HARNESS_PACKAGES)}"
    )


def _build_cached_harness(source_dir: Path) -> Path:
    sources = harness_sources(source_dir)
    units = [str(path) for path in sources if path.suffix == ".c"]
    if not units:
        raise ResourceNotFound(f"virtual Uno harness sources (*.c) are missing from {source_dir}")
    directory = cache_dir() / f"virtual-uno-{harness_digest(sources)}"
    binary = directory / "virtual-uno"
    if binary.is_file() and os.access(binary, os.X_OK):
        return binary
    wanted = os.environ.get("CC")
    compiler = shutil.which(wanted) if wanted else (shutil.which("cc") or shutil.which("gcc"))
    if compiler is None:
        raise ResourceNotFound(f"no C compiler to build the virtual Uno harness: {_install_hint()}")
    directory.mkdir(parents=True, exist_ok=True)
    # One build at a time per cache entry: concurrent test workers wait for the first.
    with open(directory / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if binary.is_file():
            return binary
        _log.info("building the virtual Uno harness into %s", directory)
        with tempfile.NamedTemporaryFile(dir=directory, prefix=".build-", delete=False) as tmp:
            partial = Path(tmp.name)
        command = [
            compiler,
            *_HARNESS_CFLAGS,
            "-o",
            str(partial),
            *units,
            *_HARNESS_LIBS,
        ]
        result = subprocess.run(command, capture_output=True, text=True, check=False)
        if result.returncode != 0:
            partial.unlink(missing_ok=True)
            detail = result.stderr.strip().splitlines()
            missing = any("No such file" in line or "cannot find -l" in line for line in detail)
            lines = "; ".join(detail[:3])
            if missing:
                raise ResourceNotFound(
                    f"cannot build the virtual Uno harness ({lines}): {_install_hint()}"
                )
            raise ResourceNotFound(f"building the virtual Uno harness failed: {lines}")
        partial.chmod(0o755)
        partial.replace(binary)
    return binary
