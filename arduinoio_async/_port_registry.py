"""Boards that programs on this machine announce: a discovery source beside USB.

A board behind a pseudo-terminal -- a virtual Uno that ``arduinoio sim`` runs -- has no
USB vendor ID, so enumerating serial ports cannot find it, and naming its port each time
(``--ports``, ``ARDUINOIO_PORTS``) is what a new user does not know to do.  So the program
that runs it announces it: one JSON file per process in a per-user directory
(``$ARDUINOIO_REGISTRY_DIR``, else ``$XDG_RUNTIME_DIR/arduinoio_async/boards``, else
``boards`` in the user cache), written when its boards are up and removed when it exits.
Discovery (:func:`arduinoio_async.manager.candidate_ports`) reads the directory like it
lists USB devices; the port is then probed like any other, so nothing downstream knows or
cares where the port came from.

A program killed without a chance to clean up leaves its file behind: entries whose
process is gone are skipped (and their file removed), as are ports that no longer exist.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._resources import cache_dir

__all__ = ["ENV_REGISTRY_DIR", "RegisteredPort", "announce", "registered_ports", "registry_dir"]

logger = logging.getLogger(__name__)

#: Overrides where announcements live (tests point it at a directory of their own).
ENV_REGISTRY_DIR = "ARDUINOIO_REGISTRY_DIR"


@dataclass(frozen=True, slots=True)
class RegisteredPort:
    """One announced board: its port, and what the announcing program said about it."""

    port: str
    pid: int
    board_id: int | None = None
    baud: int | None = None


def registry_dir() -> Path:
    """The directory of announcements (not created until a program announces)."""
    env = os.environ.get(ENV_REGISTRY_DIR)
    if env:
        return Path(env)
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime:
        return Path(runtime) / "arduinoio_async" / "boards"
    return cache_dir() / "boards"


@contextlib.contextmanager
def announce(boards: Sequence[Mapping[str, Any]]) -> Iterator[Path]:
    """Announce ``boards`` (each with ``port``; ``id`` and ``baud`` optional) while the
    block runs; the file is written whole (a reader never sees half of it)."""
    directory = registry_dir()
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    path = directory / f"{os.getpid()}.json"
    partial = path.with_suffix(".tmp")
    partial.write_text(json.dumps({"pid": os.getpid(), "boards": [dict(b) for b in boards]}))
    partial.replace(path)
    try:
        yield path
    finally:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process: alive
    return True


def registered_ports() -> list[RegisteredPort]:
    """Every board announced by a program that still runs, on a port that still exists."""
    directory = registry_dir()
    try:
        files = sorted(directory.glob("*.json"))
    except OSError:
        return []
    found: list[RegisteredPort] = []
    for path in files:
        try:
            record = json.loads(path.read_text())
            pid = int(record["pid"])
            boards = list(record["boards"])
        except (OSError, ValueError, KeyError, TypeError):
            logger.debug("skipping unreadable announcement %s", path)
            continue
        if not _alive(pid):
            with contextlib.suppress(OSError):
                path.unlink()  # its program was killed before it could clean up
            continue
        for board in boards:
            port = str(board.get("port", "")) if isinstance(board, dict) else ""
            if not port or not os.path.exists(port):
                continue
            board_id = board.get("id")
            baud = board.get("baud")
            found.append(
                RegisteredPort(
                    port,
                    pid,
                    board_id if isinstance(board_id, int) else None,
                    baud if isinstance(baud, int) else None,
                )
            )
    return found
