"""Render the pins-per-function table of ``docs/boards.md`` from the board models.

The page's prose is written by hand; the table between the ``BEGIN GENERATED`` and ``END
GENERATED`` markers is rendered from :mod:`arduinoio_async.protocol.boards`, the data the
library checks pins against and the firmware's description tables come from, so the page
cannot drift from either (``tests/protocol/test_generated.py`` checks).

    python -m arduinoio_async.protocol.boards_doc     # rewrite the generated block
"""

from __future__ import annotations

from pathlib import Path

from .boards import BOARD_MODELS, WIRE_FUNCTIONS
from .docgen import rewrite_block, splice_block

__all__ = ["BEGIN", "DOC_PATH", "END", "main", "render", "splice"]

DOC_PATH = Path("docs/boards.md")
BEGIN = "<!-- BEGIN GENERATED: python -m arduinoio_async.protocol.boards_doc -->"
END = "<!-- END GENERATED -->"


def render() -> str:
    """One column per board model, one row per function."""
    models = list(BOARD_MODELS.values())
    out = [
        "| | " + " | ".join(f"{m.name} (`{m.key}`)" for m in models) + " |",
        "|---|" + "---|" * len(models),
        "| MCU | " + " | ".join(m.mcu for m in models) + " |",
        "| USB bridge | " + " | ".join(m.bridge for m in models) + " |",
        "| model ID on the wire | " + " | ".join(f"{m.model_id}" for m in models) + " |",
        "| pins | "
        + " | ".join(f"{m.digital_pins} digital, {m.analog_pins} analog" for m in models)
        + " |",
    ]
    for function in WIRE_FUNCTIONS:
        cells = " | ".join(m.pin_ranges(function) for m in models)
        out.append(f"| {function.value} | {cells} |")
    return "\n".join(out)


def splice(document: str) -> str:
    """``document`` with its generated block replaced by a fresh rendering."""
    return splice_block(document, BEGIN, END, render())


def main(argv: list[str] | None = None) -> int:
    return rewrite_block(DOC_PATH, BEGIN, END, render)


if __name__ == "__main__":
    raise SystemExit(main())
