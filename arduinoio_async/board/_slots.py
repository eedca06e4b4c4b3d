"""Which numbered slot of a board class a new handle takes (encoders, sonars, pulse
inputs), and how a two-pin handle (encoder, sonar) takes both its pins.

The board keeps a fixed number of slots per class; the role table knows which live
handles hold which.  One rule for every class: the lowest free slot by default, or the one
asked for if it exists and is free, with the same errors.

On a served board the slots are shared by every client and a client sees only its own
handles, so the server refuses a slot another live client holds with ``SLOT_BUSY``
(naming the slot and its holder); :func:`take_slot` then moves a set-up that did not
name its slot on to the next free one, so a default slot never collides.  A local board
never sends ``SLOT_BUSY``.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Collection
from typing import TYPE_CHECKING, Any, TypeVar

from .. import protocol as p
from ..errors import BoardError, UsageError, ValueRangeError

if TYPE_CHECKING:
    from ._core import BoardCore
    from .roles import RoleHolder

__all__ = ["choose_slot", "set_up_pair", "take_slot"]

H = TypeVar("H")


def choose_slot(
    board: BoardCore,
    kind: type,
    count: int,
    slot: int | None,
    what: str,
    others: Collection[int] = (),
) -> int:
    """The slot of ``count`` a new ``kind`` handle takes (``what`` names the class in
    errors): ``slot`` if given, else the lowest one no live ``kind`` handle holds and
    not in ``others`` (slots another client of a served board holds)."""
    used = set(others) | {
        getattr(claim.handle, "slot", None)
        for claim in board.roles.values()
        if isinstance(claim.handle, kind) and not claim.handle.released
    }
    if slot is None:
        free = [s for s in range(count) if s not in used]
        if not free:
            by = " (some by other clients)" if others else ""
            raise UsageError(
                f"all {count} {what} slots of {board} are in use{by}: release one first"
            )
        return free[0]
    if not 0 <= slot < count:
        raise ValueRangeError(f"{what} slot", slot, f"0-{count - 1}")
    if slot in used:
        raise UsageError(f"{what} slot {slot} of {board} is in use: release it first")
    return slot


async def take_slot(
    board: BoardCore,
    kind: type,
    count: int,
    slot: int | None,
    what: str,
    set_up: Callable[[int], Awaitable[H]],
) -> H:
    """``set_up(s)`` in the slot :func:`choose_slot` gives; if ``slot`` was not named and
    the server of a served board refuses the chosen one with ``SLOT_BUSY`` (another
    client holds it), the next free one, until none is left (then UsageError).

    A named slot's refusal is raised as it is: it names the slot and its holder.  Each
    round awaits the board, and there are at most ``count`` rounds.
    """
    others: set[int] = set()
    while True:
        chosen = choose_slot(board, kind, count, slot, what, others)
        try:
            return await set_up(chosen)
        except BoardError as exc:
            if slot is not None or exc.code is not p.ErrorCode.SLOT_BUSY:
                raise
            others.add(chosen)


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
