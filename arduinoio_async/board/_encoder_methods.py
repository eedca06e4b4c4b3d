"""The board's encoder method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: it combines the pin-role machinery (both pins of an
encoder are claimed before anything is sent, refused with :class:`PinRoleError` naming
the pin's other user) with :mod:`arduinoio_async.board.encoders`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import UsageError, ValueRangeError
from ..protocol.pins import DigitalPin, Function
from ..protocol.pins import require as require_capable
from .encoders import Encoder, ModeName, encoder_mode

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["EncoderMethods"]


def _slots_in_use(board: BoardCore) -> set[int]:
    return {
        claim.handle.slot
        for claim in board.roles.values()
        if isinstance(claim.handle, Encoder) and not claim.handle.released
    }


class EncoderMethods:
    """``board.encoder()``: quadrature encoders decoded by the board."""

    async def encoder(
        self,
        a: DigitalPin,
        b: DigitalPin,
        *,
        mode: ModeName | int | p.EncoderMode = "x4",
        slot: int | None = None,
    ) -> Encoder:
        """A quadrature encoder on any two digital pins, counting from 0.

        ``mode``: ``"x4"`` counts every edge of A and B, ``"x2"`` every edge of A, ``"x1"``
        one per cycle.  ``slot`` (0-3) is where the board keeps it and its place in the
        stream's encoder values; by default the lowest free one.  The board turns on the
        pins' pull-ups (open-collector encoders need them).  Raises PinCapabilityError,
        PinRoleError (a pin held by another role, named) or ValueRangeError.
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.ENCODER, "quadrature encoders")
        require_capable(a, Function.ENCODER)
        require_capable(b, Function.ENCODER)
        assert isinstance(a, DigitalPin) and isinstance(b, DigitalPin)
        if a is b:
            raise ValueRangeError("encoder pin B", b.name, "a pin other than A")
        decoding = encoder_mode(mode)
        used = _slots_in_use(board)
        if slot is None:
            free = [s for s in range(p.ENCODER_SLOTS) if s not in used]
            if not free:
                raise UsageError(
                    f"all {p.ENCODER_SLOTS} encoder slots of {board} are in use: "
                    "release an encoder first"
                )
            slot = free[0]
        elif not 0 <= slot < p.ENCODER_SLOTS:
            raise ValueRangeError("encoder slot", slot, f"0-{p.ENCODER_SLOTS - 1}")
        elif slot in used:
            raise UsageError(f"encoder slot {slot} of {board} is in use: release it first")
        handle = Encoder(board, a, b, slot, decoding)
        roles = board.roles
        roles.check_free(handle)
        roles.check_free(handle.partner)
        setup = p.EncoderConfig(slot, int(a), int(b), decoding)
        roles.claim(handle, setup)
        try:
            roles.claim(handle.partner, setup)
        except BaseException:
            roles.withdraw(handle, None)
            raise
        try:
            await board.request(setup)
        except BaseException:
            roles.withdraw(handle.partner, None)
            roles.withdraw(handle, None)
            raise
        return handle
