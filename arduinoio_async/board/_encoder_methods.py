"""The board's encoder method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: it combines the pin-role machinery (both pins of an
encoder are claimed before anything is sent, refused with :class:`PinRoleError` naming
the pin's other user) with :mod:`arduinoio_async.board.encoders`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin, Function
from ._slots import set_up_pair, take_slot
from .encoders import Encoder, ModeName, encoder_mode

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["EncoderMethods"]


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
        board.model.require(a, Function.ENCODER)
        board.model.require(b, Function.ENCODER)
        assert isinstance(a, DigitalPin) and isinstance(b, DigitalPin)
        if a is b:
            raise ValueRangeError("encoder pin B", b.name, "a pin other than A")
        decoding = encoder_mode(mode)

        async def set_up(chosen: int) -> Encoder:
            handle = Encoder(board, a, b, chosen, decoding)
            setup = p.EncoderConfig(chosen, int(a), int(b), decoding)
            await set_up_pair(board, handle, handle.partner, setup, setup)
            return handle

        return await take_slot(board, Encoder, p.ENCODER_SLOTS, slot, "encoder", set_up)
