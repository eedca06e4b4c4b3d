"""The board's sonar methods, mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: it combines the pin-role machinery (both pins of a
sonar are claimed before anything is sent, refused with :class:`PinRoleError` naming the
pin's other user) with :mod:`arduinoio_async.board.sonars`.  The firing period and the
speed of sound are the board's, for every sonar: each echo pin's claim carries the
SONAR TIMING in force, so a board that reset gets them back with its sonars.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import ValueRangeError
from ..protocol.pins import DigitalPin, Function
from ..protocol.pins import require as require_capable
from ._slots import set_up_pair, take_slot
from .sonars import Sonar, SonarEcho, speed_of_sound

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["DEFAULT_TIMING", "SonarMethods"]

#: The board's timing after a boot: a firing every 60 ms, 343.0 m/s.
DEFAULT_TIMING = p.SonarTiming(60, p.SONAR_DEFAULT_SPEED_DM_S)


def _timing(board: BoardCore) -> p.SonarTiming:
    timing = getattr(board, "_sonar_timing", DEFAULT_TIMING)
    assert isinstance(timing, p.SonarTiming)
    return timing


class SonarMethods:
    """``board.sonar()`` and ``board.sonar_timing()``: rangers fired in turn by the board."""

    async def sonar(
        self, trigger: DigitalPin, echo: DigitalPin, *, slot: int | None = None
    ) -> Sonar:
        """An HC-SR04 style sonar with its trigger and echo on any two digital pins.

        ``slot`` (0-3) is where the board keeps it, its turn in the firing order and its
        place in the stream's sonar block; by default the lowest free one.  Raises
        PinCapabilityError, PinRoleError (a pin held by another role, named),
        ValueRangeError or FirmwareFeatureError (an image without sonars, naming the
        ones that have them).
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.SONAR, "sonars")
        require_capable(trigger, Function.SONAR)
        require_capable(echo, Function.SONAR)
        assert isinstance(trigger, DigitalPin) and isinstance(echo, DigitalPin)
        if trigger is echo:
            raise ValueRangeError("sonar echo pin", echo.name, "a pin other than the trigger")

        async def set_up(chosen: int) -> Sonar:
            handle = Sonar(board, trigger, echo, chosen)
            setup = p.SonarConfig(chosen, int(trigger), int(echo))
            await set_up_pair(board, handle, handle.partner, setup, _timing(board))
            return handle

        return await take_slot(board, Sonar, p.SONAR_SLOTS, slot, "sonar", set_up)

    async def sonar_timing(
        self,
        *,
        period_ms: int = 60,
        speed_m_s: float | None = None,
        temperature_c: float | None = None,
    ) -> None:
        """Set how often the board fires a sonar and the speed of sound it uses.

        ``period_ms`` (1-65535): from one firing to the next; with n sonars each fires
        every n periods (never before the previous echo ended or timed out).  The speed:
        ``speed_m_s`` (300.0-400.0), or ``temperature_c`` for air at that temperature, or
        neither for 343.0 m/s (20 C).
        """
        board = cast("BoardCore", self)
        board.require_feature(p.Feature.SONAR, "sonars")
        if not isinstance(period_ms, int) or not 1 <= period_ms <= 0xFFFF:
            raise ValueRangeError("sonar period_ms", period_ms, "1-65535")
        if speed_m_s is not None and temperature_c is not None:
            raise ValueRangeError("sonar speed", "both speed_m_s and temperature_c", "one of them")
        speed = 343.0
        if temperature_c is not None:
            if not (math.isfinite(temperature_c) and -40.0 <= temperature_c <= 85.0):
                raise ValueRangeError("sonar temperature_c", temperature_c, "-40 to 85")
            speed = speed_of_sound(temperature_c)
        elif speed_m_s is not None:
            speed = speed_m_s
        if not (math.isfinite(speed) and 300.0 <= speed <= 400.0):
            raise ValueRangeError("sonar speed_m_s", speed_m_s, "300.0-400.0")
        timing = p.SonarTiming(period_ms, round(speed * 10))
        await board.request(timing)
        board._sonar_timing = timing  # type: ignore[attr-defined]
        for claim in list(board.roles.values()):
            if isinstance(claim.handle, SonarEcho) and not claim.handle.released:
                board.roles.amend(claim.handle, timing)
