"""The API reference shows every public class, function, method and property.

mkdocstrings leaves out a member without a docstring without a word, so the reference
once missed ``Board.digital_output`` and ``AnalogInput.read_volts``.  The first test
fails on a public member without a docstring, naming it; the second builds the site
(``make docs``: a strict MkDocs build, a few seconds) and checks the rendered pages have
an anchor for each of them, which also catches a member hidden by a private base class
or by a directive's options.  What counts as documented is :mod:`tests.docs.reference`.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import FunctionType

import pytest

import arduinoio_async

from .reference import REPO, anchors_in, docstring_of, documented_objects

OBJECTS = documented_objects()


def test_the_reference_lists_the_everyday_methods() -> None:
    names = {anchor for item in OBJECTS for anchor in item.anchors}
    for everyday in (
        "arduinoio_async.board.Board.digital_output",
        "arduinoio_async.board.handles.AnalogInput.read_volts",
        "arduinoio_async.blocking.BlockingBoard.gpio",
        "arduinoio_async.board.handles.Gpio.watch",
    ):
        assert everyday in names


def test_everything_the_package_exports_is_in_the_reference() -> None:
    """``from arduinoio_async import X``: X is documented on some reference page."""
    documented = {id(item.obj) for item in OBJECTS}
    absent = [
        name
        for name in arduinoio_async.__all__
        if isinstance(value := getattr(arduinoio_async, name), type | FunctionType)
        and id(value) not in documented
    ]
    assert not absent, f"exported by the package, in no reference page: {absent}"


def test_every_public_member_has_a_docstring() -> None:
    """A docstring of three words at least: "TODO" or "Write." is no documentation."""
    missing = [
        f"{item.name} ({item.page.name})"
        for item in OBJECTS
        if len(docstring_of(item.obj).split()) < 3
    ]
    assert not missing, "public members without a docstring:\n" + "\n".join(missing)


def test_the_built_reference_shows_every_public_member(tmp_path: Path) -> None:
    site = tmp_path / "site"
    mkdocs = Path(sys.executable).with_name("mkdocs")
    result = subprocess.run(
        [str(mkdocs), "build", "--strict", "--quiet", "--site-dir", str(site)],
        cwd=REPO,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if result.returncode != 0:
        pytest.fail(f"mkdocs build --strict failed:\n{result.stdout}\n{result.stderr}")
    anchors: set[str] = set()
    for page in (site / "reference").rglob("index.html"):
        anchors |= anchors_in(page.read_text())
    hidden = [
        f"{item.name} ({item.page.name})"
        for item in OBJECTS
        if not any(anchor in anchors for anchor in item.anchors)
    ]
    assert not hidden, "members the built reference does not show:\n" + "\n".join(hidden)
