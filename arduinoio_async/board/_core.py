"""The part of a board its handles, watches and failsafe use: :class:`BoardCore`.

The handle modules (:mod:`.handles`, :mod:`.changes`, :mod:`.streaming`,
:mod:`.transactions`, :mod:`.motors`) and the failsafe are typed against this protocol,
not against :class:`~arduinoio_async.board.Board`: they sit *below* the board in the
import graph (the board builds them; they never import it), and what a handle may ask of
its board is written down here, in one place.  :class:`~arduinoio_async.board.Board` is
the one implementation; a test double needs only these members.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from .. import protocol as p

if TYPE_CHECKING:
    from ..protocol.boards import BoardModel
    from ..protocol.pins import DigitalPin
    from ..transport import Transport
    from .roles import PinRoles, RoleHolder
    from .watches import Watches

__all__ = ["BoardCore"]

R = TypeVar("R", bound=p.Reply)


class BoardCore(Protocol):
    """What a handle may use of its board: its identity, link, records and requests."""

    board_id: int
    capabilities: p.ReadCapabilitiesReply
    #: What the board said it is and which pins can do what (the Uno's Table III for an
    #: image that cannot say): every pin is checked against it before anything is sent.
    model: BoardModel
    #: The session tag this library gave the board's current boot (0: none yet).
    session: int
    #: The change, counter, analog and stream subscriptions, restored after a reset.
    watches: Watches

    @property
    def link(self) -> Transport:
        """The current transport (raises BoardDisconnectedError while there is none)."""
        ...

    @property
    def roles(self) -> PinRoles:
        """Which pin holds which role."""
        ...

    async def request(self, request: p.Request[R], *, timeout: float | None = None) -> R:
        """Send ``request`` and return its verified reply."""
        ...

    async def set_up(self, handle: RoleHolder, setup: p.Request[Any]) -> None:
        """Give ``handle`` its pin by sending ``setup`` and record the role."""
        ...

    async def release(self, pin: DigitalPin) -> None:
        """End whatever role ``pin`` has, on the board and here."""
        ...

    def require_feature(self, feature: p.Feature, what: str) -> None:
        """Raise FirmwareFeatureError (nothing sent) unless the firmware has ``feature``."""
        ...
