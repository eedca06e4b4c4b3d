"""Where the virtual Uno's harness and firmware come from, and how the simulator fails.

The harness binary and the firmware images are found (or, for the harness, built into a
per-user cache) by :mod:`arduinoio_async._resources`; these functions turn "not found"
into :class:`SimulatorNotAvailable` with the install hint, a distinct class so that test
suites can skip on machines without simavr instead of failing.
"""

from __future__ import annotations

import os
from pathlib import Path

from .. import _resources
from ..errors import ArduinoIOError
from ..protocol.profiles import DEFAULT_PROFILE

__all__ = [
    "INSTALL_HINT",
    "SimulatorError",
    "SimulatorNotAvailable",
    "find_firmware_elf",
    "find_harness_binary",
    "find_test_firmware",
]

#: What to install or build when the simulator cannot run, for the error messages.
INSTALL_HINT = (
    "from a clone: `make firmware sim` (needs `apt-get install simavr libsimavr-dev libelf-dev "
    "gcc-avr avr-libc`); installed from a wheel, the harness is built on first use and needs "
    f"`sudo apt-get install {' '.join(_resources.HARNESS_PACKAGES)}`"
)


class SimulatorNotAvailable(ArduinoIOError):
    """The virtual Uno cannot run here: harness binary, firmware ELF or simavr is missing.

    A distinct class lets test suites skip (instead of fail) on machines without simavr.
    """


class SimulatorError(ArduinoIOError):
    """The harness refused a control command or stopped unexpectedly."""


def find_harness_binary() -> Path:
    """Locate ``virtual-uno``, building it into the user cache if needed (see ``_resources``).

    ``$ARDUINOIO_SIM_BIN`` wins.  Blocking (a first build takes a few seconds): async code
    calls it through :func:`anyio.to_thread.run_sync`.
    """
    try:
        return _resources.harness_binary()
    except _resources.ResourceNotFound as exc:
        raise SimulatorNotAvailable(
            f"virtual Uno harness unavailable: {exc}; {INSTALL_HINT}"
        ) from exc


def find_firmware_elf(baud: int, profile: str = DEFAULT_PROFILE, board: str = "uno") -> Path:
    """Locate the project firmware ELF of build ``profile`` (``board``'s) for ``baud``
    (``$ARDUINOIO_FIRMWARE_DIR`` overrides the directory)."""
    try:
        return _resources.firmware_image(baud, "elf", profile, board)
    except (_resources.ResourceNotFound, ValueError) as exc:
        raise SimulatorNotAvailable(str(exc)) from exc


def find_test_firmware(baud: int) -> Path:
    """Locate the harness's own echo/test firmware (``firmware/sim/testfw``, clones only)."""
    tree = _resources.source_tree()
    env = os.environ.get(_resources.ENV_SIM_BIN)
    directory = (
        Path(env).parent
        if env
        else (tree / "firmware" / "sim" / "build" if tree is not None else None)
    )
    path = directory / f"testfw-{baud}.elf" if directory is not None else None
    if path is None or not path.is_file():
        raise SimulatorNotAvailable(
            f"test firmware testfw-{baud}.elf not found (a clone builds it with `make sim`)"
        )
    return path
