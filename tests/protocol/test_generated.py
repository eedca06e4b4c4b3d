"""The firmware header and the spec's layout tables are renderings of the Python table."""

from __future__ import annotations

from pathlib import Path

from arduinoio_async.protocol import boards_doc, cheader, docgen

#: The clone's root: the generators' paths are relative to it.
REPO = Path(__file__).resolve().parents[2]


def test_committed_c_header_matches_the_command_table() -> None:
    committed = (REPO / cheader.HEADER_PATH).read_text()
    assert committed == cheader.render(), (
        "firmware/include/aio_protocol.h drifted from the Python command table: run "
        "`python -m arduinoio_async.protocol.cheader`"
    )


def test_protocol_doc_layouts_match_the_command_table() -> None:
    committed = (REPO / docgen.DOC_PATH).read_text()
    assert committed == docgen.splice(committed), (
        "docs/protocol.md's generated block drifted: "
        "run `python -m arduinoio_async.protocol.docgen`"
    )


def test_boards_page_pin_table_matches_the_board_models() -> None:
    committed = (REPO / boards_doc.DOC_PATH).read_text()
    assert boards_doc.BEGIN in committed
    assert committed == boards_doc.splice(committed), (
        "docs/boards.md's pin table drifted from protocol/boards.py: "
        "run `python -m arduinoio_async.protocol.boards_doc`"
    )


def test_header_names_every_request() -> None:
    from arduinoio_async import protocol as p

    text = cheader.render()
    assert text.count("    X(") == len(p.REQUEST_TYPES)
