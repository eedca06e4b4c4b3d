"""Render the byte layouts of every command for ``docs/protocol.md``.

The prose of the specification is written by hand; the per-command layout tables between
the ``BEGIN GENERATED`` and ``END GENERATED`` markers are rendered from the same message
table as the firmware header, so the document cannot drift from the code (a test checks).

    python -m arduinoio_async.protocol.docgen           # rewrite the generated block
"""

from __future__ import annotations

import sys
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


def splice(document: str) -> str:
    """``document`` with its generated block replaced by a fresh rendering."""
    head, _, rest = document.partition(BEGIN)
    _, _, tail = rest.partition(END)
    return f"{head}{BEGIN}\n{render_layouts()}\n{END}{tail}"


def main(argv: list[str] | None = None) -> int:
    if not DOC_PATH.is_file():
        print(f"{DOC_PATH} not found: run this from a clone of the project", file=sys.stderr)
        return 1
    text = DOC_PATH.read_text()
    if BEGIN not in text or END not in text:
        print(f"{DOC_PATH} lacks the generated-block markers", file=sys.stderr)
        return 1
    DOC_PATH.write_text(splice(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
