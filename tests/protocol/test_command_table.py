"""How the command table is written down: one module per firmware module, echoed fields
declared once, every message importable from ``arduinoio_async.protocol``, retry rules
as the specification states them."""

from __future__ import annotations

import inspect
import re
from pathlib import Path
from typing import Any

import pytest

from arduinoio_async import protocol as p
from arduinoio_async.protocol import cheader, commands
from arduinoio_async.protocol._layout import Frame

#: The clone's root (the firmware sources and the spec are read from it).
REPO = Path(__file__).resolve().parents[2]

MESSAGES: list[type[Frame]] = [
    *p.REQUEST_TYPES.values(),
    *p.REPLY_TYPES.values(),
    *p.EVENT_TYPES.values(),
]
SENT_FIRST: list[type[Frame]] = [*p.REQUEST_TYPES.values(), *p.EVENT_TYPES.values()]


def _macro(cls: type[Frame]) -> str:
    layout = cls.LAYOUT
    return f"AIO_DT_{p.ClassTag(layout.class_tag).name}_{cheader._command_name(layout)}"


@pytest.mark.parametrize("cls", SENT_FIRST, ids=lambda c: c.__name__)
def test_each_message_lives_in_the_module_named_for_its_firmware_handler(
    cls: type[Frame],
) -> None:
    module = cls.__module__.rpartition(".")[2]
    source = REPO / f"firmware/src/{module}.c"
    assert source.is_file(), f"{cls.__name__} is in {module}.py, which mirrors no firmware module"
    # a firmware module split in files keeps the name as their prefix (stepper_cmd.c)
    parts = [source, *sorted(source.parent.glob(f"{module}_*.c"))]
    handled = any(_macro(cls) in part.read_text() for part in parts)
    assert handled, f"{', '.join(f.name for f in parts)} do not handle {cls.__name__}"


def test_every_message_is_exported_once_from_the_protocol_package() -> None:
    assert len(p.__all__) == len(set(p.__all__))
    exported = [name for module in commands.MODULES for name in module.__all__]
    for cls in MESSAGES:
        assert exported.count(cls.__name__) == 1, cls.__name__
        assert cls.__name__ in p.__all__
        assert getattr(p, cls.__name__) is cls
    assert set(exported) <= set(p.__all__)


def _declaring_class(cls: type[Any], name: str) -> type[Any]:
    return next(base for base in cls.__mro__ if name in inspect.get_annotations(base))


@pytest.mark.parametrize("request_cls", list(p.REQUEST_TYPES.values()), ids=lambda c: c.__name__)
def test_echoed_fields_are_declared_once_for_request_and_reply(
    request_cls: type[p.Request[Any]],
) -> None:
    """A field the reply must repeat comes from one declaration both classes inherit."""
    for name in request_cls.ECHO:
        assert _declaring_class(request_cls, name) is _declaring_class(request_cls.REPLY, name)


def _retry_columns() -> list[set[str]]:
    text = (REPO / "docs/protocol.md").read_text()
    header = "| retried (reads only) | retried (sets a state) | never retried"
    row = text.partition(header)[2].splitlines()[2]
    return [
        {re.sub(r" \(.*\)", "", name).strip() for name in cell.split(",")}
        for cell in row.strip("|").split("|")
    ]


def _command(cls: type[Frame]) -> str:
    return cheader._snake(cls.__name__)


def test_retry_rules_are_the_ones_the_specification_lists() -> None:
    reads_only, sets_state, never = _retry_columns()
    assert {_command(cls) for cls in commands.READ_ONLY_REQUESTS} == reads_only
    assert {_command(cls) for cls in commands.IDEMPOTENT_WRITES} == sets_state
    rest = {_command(cls) for cls in p.REQUEST_TYPES.values() if not cls.IDEMPOTENT}
    assert rest == never
