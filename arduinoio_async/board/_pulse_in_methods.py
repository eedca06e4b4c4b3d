"""The board's pulse-input method, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: it combines the pin-role machinery (the pin is
claimed before anything is sent, refused with :class:`PinRoleError` naming the pin's other
user) with :mod:`arduinoio_async.board.pulse_inputs`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin, Function
from ._slots import take_slot
from .pulse_inputs import DEFAULT_CENTRE_US, DEFAULT_HIGH_US, DEFAULT_LOW_US, PulseInput

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["PulseInMethods"]


class PulseInMethods:
    """``board.pulse_input()``: high-pulse widths timed by the board (RC receivers)."""

    async def pulse_input(
        self,
        pin: DigitalPin,
        *,
        timeout_ms: int = 100,
        slot: int | None = None,
        low_us: int = DEFAULT_LOW_US,
        centre_us: int = DEFAULT_CENTRE_US,
        high_us: int = DEFAULT_HIGH_US,
    ) -> PulseInput:
        """Time the high pulses on any digital pin; the signal is lost after ``timeout_ms``
        (1-65535) without one.

        ``slot`` (0-5) is where the board keeps it; by default the lowest free one.
        ``low_us``/``centre_us``/``high_us``: the end points of :meth:`PulseInput.position`
        and :meth:`PulseInput.throttle`.  Raises PinCapabilityError, PinRoleError (a pin
        held by another role, named), ValueRangeError or FirmwareFeatureError (an image
        without pulse inputs, naming the ones that have them).
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.PULSE_IN, "pulse-width inputs")
        board.model.require(pin, Function.PULSE_IN)
        assert isinstance(pin, DigitalPin)
        if not 1 <= timeout_ms <= 0xFFFF:
            raise ValueRangeError("pulse input timeout_ms", timeout_ms, "1-65535")

        async def set_up(chosen: int) -> PulseInput:
            handle = PulseInput(
                board, pin, chosen, timeout_ms, low_us=low_us, centre_us=centre_us, high_us=high_us
            )
            roles = board.roles
            roles.check_free(handle)
            setup = p.PulseInConfig(chosen, int(pin), timeout_ms)
            roles.claim(handle, setup)
            try:
                await board.request(setup)
            except BaseException:
                roles.withdraw(handle, None)
                raise
            return handle

        return await take_slot(board, PulseInput, p.PULSE_IN_SLOTS, slot, "pulse input", set_up)
