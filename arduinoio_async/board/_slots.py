"""Which numbered slot of a board class a new handle takes (encoders, pulse inputs).

The board keeps a fixed number of slots per class; the role table knows which live
handles hold which.  One rule for every class: the lowest free slot by default, or the one
asked for if it exists and is free, with the same errors.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import UsageError, ValueRangeError

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["choose_slot"]


def choose_slot(board: BoardCore, kind: type, count: int, slot: int | None, what: str) -> int:
    """The slot of ``count`` a new ``kind`` handle takes (``what`` names the class in
    errors): ``slot`` if given, else the lowest one no live ``kind`` handle holds."""
    used = {
        getattr(claim.handle, "slot", None)
        for claim in board.roles.values()
        if isinstance(claim.handle, kind) and not claim.handle.released
    }
    if slot is None:
        free = [s for s in range(count) if s not in used]
        if not free:
            raise UsageError(f"all {count} {what} slots of {board} are in use: release one first")
        return free[0]
    if not 0 <= slot < count:
        raise ValueRangeError(f"{what} slot", slot, f"0-{count - 1}")
    if slot in used:
        raise UsageError(f"{what} slot {slot} of {board} is in use: release it first")
    return slot
