"""Pin roles set up elsewhere: by an earlier program, or by another client of a served board.

The panel's own roles are the ``Board``'s records (its handles); a role another program
gave lasts on the board until released or reset, and another client of the same served
board holds its pins right now, yet neither is in those records.  The board reports
every pin's role class (``ReadPinRoles``, as ``arduinoio status`` shows them), so
:class:`RolesElsewhere` asks for it every :data:`ROLES_INTERVAL` (no event announces
another host's set-up) and at once after each of the page's controls, and tells the panel
when the answer changes.  A pin the board has a role for and the panel has no handle for
is shown as set elsewhere, with the board's word for its role.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

import anyio

from .. import protocol as p
from ..errors import ArduinoIOError, BoardError
from ..protocol.pins import DigitalPin, Function, pin_mask

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["ROLES_INTERVAL", "RolesElsewhere", "role_words"]

logger = logging.getLogger(__name__)

#: Seconds between two reads of the board's pin roles (one small request each).
ROLES_INTERVAL = 1.0


def role_words(reply: p.ReadPinRolesReply, pin: DigitalPin) -> str | None:
    """The board's role of ``pin`` in words, or None when it has none."""
    bit = 1 << int(pin)
    if reply.gpio_input & bit:
        return "digital input"
    if reply.gpio_output & bit:
        return "digital output"
    if reply.pwm & bit:
        return "servo PWM" if pin_mask(Function.SERVO_PWM) & bit else "software PWM"
    if reply.counter & bit:
        return "counter"
    if reply.pulse_input & bit:
        return "pulse-width input"
    return None


class RolesElsewhere:
    """The board's own record of its pins' roles, kept fresh for the panel."""

    def __init__(self, board: Board, *, on_change: Callable[[], None]) -> None:
        self.board = board
        self.reply: p.ReadPinRolesReply | None = None
        self._on_change = on_change
        self._wake = anyio.Event()

    def role(self, pin: DigitalPin) -> str | None:
        """The board's role of ``pin`` in words (None: none, or not known)."""
        return None if self.reply is None else role_words(self.reply, pin)

    def refresh(self) -> None:
        """Read the roles again now (a control may have changed them)."""
        self._wake.set()

    async def run(self) -> None:
        """Read the roles until cancelled; stop for good on firmware without the request."""
        while True:
            self._wake = anyio.Event()
            if self.board.connected:
                try:
                    reply: p.ReadPinRolesReply | None = await self.board.request(p.ReadPinRoles())
                except BoardError as exc:
                    if exc.code in (p.ErrorCode.UNKNOWN_CLASS, p.ErrorCode.UNKNOWN_DESCRIPTOR):
                        logger.info("monitor: %s cannot report its pin roles", self.board)
                        return
                    reply = self.reply
                except ArduinoIOError:
                    reply = None  # not known while the link is down
                if reply != self.reply:
                    self.reply = reply
                    self._on_change()
            with anyio.move_on_after(ROLES_INTERVAL):
                await self._wake.wait()
