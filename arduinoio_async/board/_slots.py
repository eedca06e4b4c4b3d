"""Which numbered slot of a board class a new handle takes (encoders, pulse inputs), and
how a two-pin handle (encoder, sonar) takes both its pins.

The board keeps a fixed number of slots per class; the role table knows which live
handles hold which.  One rule for every class: the lowest free slot by default, or the one
asked for if it exists and is free, with the same errors.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import protocol as p
from ..errors import UsageError, ValueRangeError

if TYPE_CHECKING:
    from ._core import BoardCore
    from .roles import RoleHolder

__all__ = ["choose_slot", "set_up_pair"]


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


async def set_up_pair(
    board: BoardCore,
    handle: RoleHolder,
    partner: RoleHolder,
    setup: p.Request[Any],
    partner_setup: p.Request[Any],
) -> None:
    """Claim both pins of a two-pin handle, then send ``setup``; on any failure (a pin
    taken, the board refusing, a cancellation) neither pin stays claimed.

    Both pins are checked before either is claimed, so a refusal names the pin that is
    taken and leaves the role table as it was.  ``partner_setup`` is what the second
    pin's role replays after a reset.
    """
    roles = board.roles
    roles.check_free(handle)
    roles.check_free(partner)
    roles.claim(handle, setup)
    try:
        roles.claim(partner, partner_setup)
    except BaseException:
        roles.withdraw(handle, None)
        raise
    try:
        await board.request(setup)
    except BaseException:
        roles.withdraw(partner, None)
        roles.withdraw(handle, None)
        raise
