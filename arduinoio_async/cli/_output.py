"""Tables for people and for programs: rich on a terminal, plain text when piped, or JSON.

A rich table written to a pipe is squeezed to 80 columns and wraps, which breaks
``grep`` and ``awk``; so when stdout is not a terminal a table is printed as plain,
aligned columns without borders, and ``--json`` prints the rows themselves.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from rich.console import Console
from rich.table import Table

__all__ = ["print_record", "print_rows"]


def _text(value: Any) -> str:
    return "-" if value is None else str(value)


def print_rows(
    console: Console,
    title: str,
    columns: Sequence[tuple[str, str]],
    rows: Sequence[Mapping[str, Any]],
    *,
    as_json: bool,
    shown: Sequence[Mapping[str, str]] | None = None,
) -> None:
    """Rows as JSON, a rich table or plain columns.

    ``columns`` are (key, heading) pairs; ``shown`` optionally gives the display text of
    each row (for example IDs in hex) while JSON keeps the raw values.
    """
    if as_json:
        console.print_json(json.dumps(list(rows)))
        return
    cells = [
        [_text((shown[i] if shown else row).get(key)) for key, _ in columns]
        for i, row in enumerate(rows)
    ]
    headings = [heading for _, heading in columns]
    if console.is_terminal:
        table = Table(title=title)
        for heading in headings:
            table.add_column(heading, overflow="fold")
        for line in cells:
            table.add_row(*line)
        console.print(table)
        return
    widths = [max(len(text) for text in column) for column in zip(headings, *cells, strict=True)]
    for line in [headings, *cells]:
        text = "  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True))
        console.print(text.rstrip(), highlight=False, soft_wrap=True, markup=False)


def print_record(
    console: Console,
    title: str,
    record: Mapping[str, Any],
    *,
    as_json: bool,
    raw: Mapping[str, Any] | None = None,
) -> None:
    """One object (``info``, ``status``) as JSON, a two-column table or ``key: value`` lines.

    ``record`` is what people read; ``raw`` (default: ``record``) what ``--json`` prints.
    """
    if as_json:
        console.print_json(json.dumps(dict(record if raw is None else raw)))
        return
    if console.is_terminal:
        table = Table(show_header=False, title=title)
        for key, value in record.items():
            table.add_row(key, _text(value))
        console.print(table)
        return
    for key, value in record.items():
        console.print(f"{key}: {_text(value)}", highlight=False, soft_wrap=True, markup=False)
