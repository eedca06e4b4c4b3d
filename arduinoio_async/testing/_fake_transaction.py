"""How the fake board reads a TRANSACTION's items: the firmware's rules, in Python.

Kept apart from :mod:`._fake_board` by idea: the rules that make the board refuse an item
list as a whole (firmware/src/transaction.c) are the fake's oracle for the library's own
transaction checks, so they are written once, here.
"""

from __future__ import annotations

from .. import protocol as p

__all__ = ["split_items"]


def split_items(items: bytes) -> list[bytes] | None:
    """The items of a transaction, or None when the board refuses the list as a whole
    (unknown tags, a cut item, RESET or TRANSACTION inside, results over MAX_BLOB)."""
    out: list[bytes] = []
    pos = need = 0
    while pos < len(items):
        if len(items) - pos < 2:
            return None
        cls = p.REQUEST_TYPES.get((items[pos], items[pos + 1]))
        if cls is None or cls in (p.Reset, p.Transaction, p.SetFraming):
            return None
        layout = cls.LAYOUT
        size = layout.base_size - 1
        if layout.length_offset >= 0:
            if (
                pos + layout.length_offset >= len(items)
                or items[pos + layout.length_offset] > p.MAX_BLOB
            ):
                return None
            size += items[pos + layout.length_offset]
        if pos + size > len(items):
            return None
        result = cls.REPLY.LAYOUT.base_size - 1
        if cls is p.I2CRead:
            result += min(items[pos + 4], p.MAX_BLOB + 1)
        need += max(result, p.ErrorReply.SIZE - 1)
        out.append(items[pos : pos + size])
        pos += size
    return out if out and need <= p.MAX_BLOB else None
