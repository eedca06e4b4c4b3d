"""What the API reference documents: the objects its mkdocstrings directives render.

The reference pages (``docs/reference/*.md``) name their content with ``::: dotted.path``
directives, optionally followed by an indented ``options:`` block. mkdocstrings renders,
for a module, the names in its ``__all__`` (or, without one, the classes and functions it
defines), for a class, the public methods and properties it defines, and it silently
leaves out every member without a docstring.  :func:`documented_objects` lists what a
reader should find there: every public class, function, method and property, each under
the anchor mkdocstrings gives it (its dotted path as the page documents it).  Methods a
class inherits from a base are listed under the class when the base is not rendered
itself (a private base such as ``_Watchable``): their documentation must then reach the
reader through the directive's ``inherited_members`` option.
"""

from __future__ import annotations

import enum
import importlib
import inspect
import re
import textwrap
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "docs" / "reference"
PACKAGE = "arduinoio_async"
#: PyYAML (MkDocs needs it) has no type stubs here.
yaml: Any = importlib.import_module("yaml")


@dataclass(frozen=True)
class Directive:
    """One ``::: path`` line of a reference page and its options."""

    page: Path
    path: str
    options: dict[str, Any]

    @property
    def members(self) -> list[str] | bool | None:
        """The ``members`` option: a list of names, ``False`` for none, ``None``: default."""
        members: list[str] | bool | None = self.options.get("members")
        return members


@dataclass(frozen=True)
class Documented:
    """An object the reference must show, with the anchors it may be shown under."""

    anchors: tuple[str, ...]
    obj: object
    page: Path

    @property
    def name(self) -> str:
        return self.anchors[0]


def directives() -> list[Directive]:
    """Every ``:::`` directive of the reference pages, in page order."""
    found = []
    for page in sorted(REFERENCE.glob("*.md")):
        lines = page.read_text().splitlines()
        for index, line in enumerate(lines):
            if not line.startswith("::: "):
                continue
            block = []
            for following in lines[index + 1 :]:
                if following and not following[0].isspace():
                    break
                block.append(following)
            loaded = yaml.safe_load(textwrap.dedent("\n".join(block))) if block else None
            options = (loaded or {}).get("options", {})
            found.append(Directive(page, line[4:].strip(), options))
    return found


def resolve(path: str) -> object:
    """The object a dotted path names: a module, or an attribute of the longest module."""
    parts = path.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:split]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[split:]:
            obj = getattr(obj, attribute)
        return obj
    raise LookupError(path)


def module_members(module: ModuleType, directive: Directive) -> list[str]:
    """The names a module directive renders (``members`` option, ``__all__``, or defined)."""
    members = directive.members
    if isinstance(members, list):
        return members
    if members is False:
        return []
    exported: list[str] | None = getattr(module, "__all__", None)
    if exported is not None:
        return [name for name in exported if not name.startswith("_")]
    return [
        name
        for name, value in vars(module).items()
        if not name.startswith("_")
        and (inspect.isclass(value) or inspect.isfunction(value))
        and value.__module__ == module.__name__
    ]


def _is_routine(value: object) -> bool:
    if isinstance(value, (staticmethod, classmethod)):
        value = value.__func__
    return inspect.isfunction(value) or isinstance(value, property)


def _own_package(cls: type) -> bool:
    return cls.__module__.split(".")[0] == PACKAGE


def class_members(cls: type, rendered_classes: set[type]) -> Iterator[tuple[str, object, type]]:
    """(name, member, the class that defines it) for each public method and property.

    Members of a base from this package that the reference does not render itself are
    the class's to show.  Enum members and dataclass fields are data, not listed here.
    """
    seen: set[str] = set()
    for owner in cls.__mro__:
        if owner is not cls and (not _own_package(owner) or owner in rendered_classes):
            continue
        if issubclass(owner, enum.Enum) and owner is not cls:
            continue
        for name, value in vars(owner).items():
            if name.startswith("_") or name in seen or not _is_routine(value):
                continue
            seen.add(name)
            yield name, value, owner


def documented_objects() -> list[Documented]:
    """Everything the reference pages must show, each with the anchors it may have."""
    roots: list[tuple[str, object, Directive]] = []
    for directive in directives():
        obj = resolve(directive.path)
        if isinstance(obj, ModuleType):
            roots.append((directive.path, obj, directive))
            for name in module_members(obj, directive):
                roots.append((f"{directive.path}.{name}", getattr(obj, name), directive))
        else:
            roots.append((directive.path, obj, directive))
    rendered_classes = {obj for _, obj, _ in roots if inspect.isclass(obj)}
    result = []
    for anchor, obj, directive in roots:
        if not (inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj)):
            continue  # constants and type aliases: documented by their page's prose
        result.append(Documented((anchor,), obj, directive.page))
        if not inspect.isclass(obj) or not _own_package(obj):
            continue
        for name, member, owner in class_members(obj, rendered_classes):
            anchors = [f"{anchor}.{name}"]
            anchors += [
                f"{base_anchor}.{name}"
                for base_anchor, base, _ in roots
                if base is owner and base is not obj
            ]
            result.append(Documented(tuple(anchors), member, directive.page))
    return result


def docstring_of(obj: object) -> str:
    """The object's own docstring (not one inherited from a base class or from ``object``)."""
    if isinstance(obj, (staticmethod, classmethod)):
        obj = obj.__func__
    if isinstance(obj, property):
        obj = obj.fget
    doc = getattr(obj, "__doc__", None) if not inspect.isclass(obj) else vars(obj).get("__doc__")
    return inspect.cleandoc(doc) if isinstance(doc, str) else ""


def anchors_in(html: str) -> set[str]:
    """The element ids of a rendered page: mkdocstrings' anchor for each object it shows."""
    return set(re.findall(r'\bid="([^"]+)"', html))
