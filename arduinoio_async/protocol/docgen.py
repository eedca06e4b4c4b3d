"""Render the byte layouts of every command for ``docs/protocol.md``.

The prose of the specification is written by hand; the per-command layout tables between
the ``BEGIN GENERATED`` and ``END GENERATED`` markers are rendered from the same message
table as the firmware header, so the document cannot drift from the code (a test checks).

    python -m arduinoio_async.protocol.docgen           # rewrite the generated block
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

from ._constants import FIRMWARE_BAUDS, STREAM_FRAME_OVERHEAD, ClassTag, StreamFlags
from ._layout import Layout
from ._messages import EVENT_TYPES, REQUEST_TYPES
from .commands.stream import sample_payload_size, stream_min_period_us

__all__ = ["DOC_PATH", "main", "render_layouts", "splice"]

#: The specification in a clone, relative to its root (run the generator from there).
DOC_PATH = Path("docs/protocol.md")
BEGIN = "<!-- BEGIN GENERATED: python -m arduinoio_async.protocol.docgen -->"
END = "<!-- END GENERATED -->"


def _bytes(layout: Layout, ct_text: str) -> str:
    parts = [ct_text, f"{layout.descriptor:02X}"]
    parts += [name for name, _ in layout.describe()]
    return " ".join(f"`{p}`" for p in parts) + " `CS`"


def _fields(layout: Layout) -> str:
    rows = layout.describe()
    return ", ".join(f"{name}: {wire}" for name, wire in rows) or "none"


def render_layouts() -> str:
    """Markdown tables: one row per command with request and reply bytes."""
    out = [
        "| CT | DT | request | bytes | reply | bytes | extension |",
        "|---|---|---|---|---|---|---|",
    ]
    for (ct, _dt), request in sorted(REQUEST_TYPES.items()):
        layout = request.LAYOUT
        reply = request.REPLY.LAYOUT
        ct_text = f"{ct:02X}"
        size = f"{layout.base_size}" + ("+n" if layout.blob else "")
        reply_size = f"{reply.base_size}" + ("+n" if reply.blob else "")
        out.append(
            f"| {ClassTag(ct).name} {ct_text} | {layout.descriptor:02X} | "
            f"**{request.__name__}** {_bytes(layout, ct_text)} | {size} | "
            f"**{request.REPLY.__name__}** {_bytes(reply, ct_text)} | {reply_size} | "
            f"{'yes' if request.EXTENSION else 'paper'} |"
        )
    out += ["", "Field types of each frame:", ""]
    for request in (cls for _, cls in sorted(REQUEST_TYPES.items())):
        out.append(
            f"- `{request.__name__}`: {_fields(request.LAYOUT)}; "
            f"`{request.REPLY.__name__}`: {_fields(request.REPLY.LAYOUT)}; "
            f"reply echoes: {', '.join(request.ECHO) or 'tags only'}"
        )
    out += ["", "Board-initiated frames (extension, class tag 0x40):", ""]
    for (_ct, _dt), event in sorted(EVENT_TYPES.items()):
        layout = event.LAYOUT
        out.append(f"- **{event.__name__}** {_bytes(layout, '40')}: {_fields(layout)}")
    out += [
        "",
        "Stream limits: shortest period (highest rate) the board accepts, by the rule "
        "`(12 + LEN) * 10 * 1e6 / baud <= 0.75 * period`:",
        "",
    ]
    out += [
        "| analog channels | flags | frame bytes | "
        + " | ".join(f"{baud:,} baud" for baud in FIRMWARE_BAUDS)
        + " |",
        "|---|---|---|" + "---|" * len(FIRMWARE_BAUDS),
    ]
    for channels in range(1, 7):
        for flags in (
            StreamFlags.NONE,
            StreamFlags.LEVELS | StreamFlags.EDGES | StreamFlags.COUNTERS,
        ):
            mask = (1 << channels) - 1
            frame_bytes = STREAM_FRAME_OVERHEAD + sample_payload_size(mask, flags)
            cells = []
            for baud in FIRMWARE_BAUDS:
                period = stream_min_period_us(mask, flags, baud)
                cells.append(f"{period} us ({1e6 / period:.0f} Hz)")
            label = "none" if not flags else "levels+edges+counters"
            out.append(f"| {channels} | {label} | {frame_bytes} | {' | '.join(cells)} |")
    return "\n".join(out)


def splice_block(document: str, begin: str, end: str, body: str) -> str:
    """``document`` with the block between ``begin`` and ``end`` replaced by ``body``."""
    head, _, rest = document.partition(begin)
    _, _, tail = rest.partition(end)
    return f"{head}{begin}\n{body}\n{end}{tail}"


def rewrite_block(path: Path, begin: str, end: str, render: Callable[[], str]) -> int:
    """Re-render the generated block of the doc at ``path``; 1 with a one-line error if the
    file or its markers are missing (run from a clone of the project)."""
    if not path.is_file():
        print(f"{path} not found: run this from a clone of the project", file=sys.stderr)
        return 1
    text = path.read_text()
    if begin not in text or end not in text:
        print(f"{path} lacks the generated-block markers", file=sys.stderr)
        return 1
    path.write_text(splice_block(text, begin, end, render()))
    return 0


def splice(document: str) -> str:
    """``document`` with its generated block replaced by a fresh rendering."""
    return splice_block(document, BEGIN, END, render_layouts())


def main(argv: list[str] | None = None) -> int:
    return rewrite_block(DOC_PATH, BEGIN, END, render_layouts)


if __name__ == "__main__":
    raise SystemExit(main())
