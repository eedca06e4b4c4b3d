"""The README's folder table names every folder of the clone, every module and subpackage
of the package, and every page of the docs; and everything it names exists.

A folder table that leaves things out sends a newcomer hunting (it once left out
``network/``, ``bench/``, the blocking API and most docs); this keeps it complete as the
tree grows: a new top-level module fails here until the table says what it is for.
"""

from __future__ import annotations

import re
import subprocess

import pytest

from .reference import REPO

PACKAGE = REPO / "arduinoio_async"
#: Not modules or folders a reader looks for.
IGNORED = {"__pycache__"}


def folder_table() -> dict[str, str]:
    """First-column paths of the README's "Folders" table -> the row's description."""
    text = (REPO / "README.md").read_text()
    section = text.split("\n## Folders\n", 1)[1].split("\n## ", 1)[0]
    rows: dict[str, str] = {}
    for line in section.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not cells[0].startswith("`"):
            continue
        for path in re.findall(r"`([^`]+)`", cells[0]):
            rows[path.rstrip("/")] = cells[1]
    return rows


def tracked_top_level_folders() -> set[str]:
    try:
        files = subprocess.run(
            ["git", "-C", str(REPO), "ls-files"],
            capture_output=True,
            text=True,
            check=True,
            timeout=30,
        ).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git clone: the tracked folders are unknown")
    return {name.split("/", 1)[0] for name in files if "/" in name}


def package_entries() -> set[str]:
    return {
        f"arduinoio_async/{entry.name}"
        for entry in PACKAGE.iterdir()
        if entry.name not in IGNORED and (entry.is_dir() or entry.suffix in (".py", ".typed"))
    }


def test_every_module_and_subpackage_of_the_package_is_in_the_table() -> None:
    missing = sorted(package_entries() - set(folder_table()))
    assert not missing, f"add to README.md's folder table: {missing}"


def test_every_top_level_folder_is_in_the_table() -> None:
    named = {path.split("/", 1)[0] for path in folder_table()}  # the package by its parts
    missing = sorted(tracked_top_level_folders() - named)
    assert not missing, f"add to README.md's folder table: {missing}"


def test_every_docs_page_is_in_the_docs_row() -> None:
    row = folder_table()["docs"]
    named = {name.rstrip("/") for name in re.findall(r"`([^`]+)`", row)}
    missing = sorted(entry.name for entry in (REPO / "docs").iterdir() if entry.name not in named)
    assert not missing, f"name these in README.md's docs/ row: {missing}"


def test_everything_the_table_names_exists() -> None:
    absent = sorted(path for path in folder_table() if not (REPO / path).exists())
    assert not absent, f"README.md's folder table names what is not there: {absent}"


def test_the_table_parser_sees_a_missing_row() -> None:
    """The check can fail: the table without one row misses that module."""
    table = folder_table()
    del table["arduinoio_async/manager.py"]
    assert "arduinoio_async/manager.py" in package_entries() - set(table)
