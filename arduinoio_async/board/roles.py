"""Which pin holds which role: the board's public pin-role table.

The firmware gives each pin at most one role (Table III) until it is released or the board
resets.  The host keeps its own record of the roles it gave, for three reasons:

* a second role for a busy pin is refused *before* anything is sent, with an error that
  names the pin and the role holding it (no round trip, no half-configured pin);
* a handle whose role ended is marked released, so it can never drive a pin that another
  handle may own now;
* after a reset or a replug the board has forgotten every role, and the record is exactly
  what must be replayed (:meth:`PinRoles.setups`) before handles are used again.

:class:`PinRoles` is that record.  Reading it is for anyone (``board.roles[D4].handle``,
``for pin, claim in board.roles.items()``: the monitor shows it); changing it is for the
board and its handles, which claim a pin just before sending its set-up request
(:meth:`Board.set_up <arduinoio_async.board.Board.set_up>`), amend the record when a handle
changes its set-up (a new level, a new pulse width), and release it when the role ends.
The table sends nothing itself: it is plain bookkeeping, testable without a board.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any, NamedTuple, Protocol

from .. import protocol as p
from ..errors import PinRoleError, StaleHandleError
from ..protocol.pins import DigitalPin

__all__ = ["Claim", "I2CHolder", "PinRoles", "RoleHolder"]


class RoleHolder(Protocol):
    """What the table needs of a pin handle (:class:`~arduinoio_async.board.handles.PinHandle`
    is the one in the library): kept this small so the table sits below the handles."""

    #: The role in words ("digital output", ...).
    ROLE: str
    pin: DigitalPin
    #: Set when the role ended; the handle then refuses to touch the pin.
    released: bool

    @property
    def board(self) -> object:
        """The board the handle belongs to."""
        ...

    def check_usable(self) -> None:
        """Raise StaleHandleError if the handle's role was released."""
        ...


class I2CHolder(Protocol):
    """What the table needs of the I2C bus: its speed, replayed after a reset."""

    @property
    def speed(self) -> p.I2CSpeed:
        """The bus speed the board runs."""
        ...


class Claim(NamedTuple):
    """One pin's role: the handle that holds it and the request that set it up."""

    handle: RoleHolder
    #: The request that gives the pin this role as it is now (replayed after a reset).
    setup: p.Request[Any]

    @property
    def role(self) -> str:
        """The role in words ("digital output", "servo PWM", ...)."""
        return self.handle.ROLE


class PinRoles(Mapping[DigitalPin, Claim]):
    """The roles one board's pins hold, as a read-only mapping ``pin -> Claim``.

    Pins without a role are absent.  ``owner`` is the board whose pins these are: a handle
    of another board is refused, since the same pin name there is a different wire.
    """

    def __init__(self, owner: object) -> None:
        self._owner = owner
        #: Plain (handle, setup) pairs: amended on every write, so no Claim is built there.
        self._claims: dict[DigitalPin, tuple[RoleHolder, p.Request[Any]]] = {}
        self._i2c: I2CHolder | None = None

    def __repr__(self) -> str:
        held = ", ".join(f"{pin.name}: {claim.role}" for pin, claim in self.items())
        return f"<PinRoles {{{held}}}>"

    # ---- reading -----------------------------------------------------------------------

    def __getitem__(self, pin: DigitalPin) -> Claim:
        return Claim(*self._claims[pin])

    def __iter__(self) -> Iterator[DigitalPin]:
        return iter(self._claims)

    def __len__(self) -> int:
        return len(self._claims)

    def holder(self, pin: DigitalPin) -> RoleHolder | None:
        """The handle holding ``pin``, or None if the pin has no role."""
        claim = self._claims.get(pin)
        return None if claim is None else claim[0]

    @property
    def i2c(self) -> I2CHolder | None:
        """The I2C bus when it is on (A4/A5 then belong to it), else None."""
        return self._i2c

    def setups(self) -> list[p.Request[Any]]:
        """Every request that must be replayed on a board that lost its roles, in order.

        The pins' set-ups in the order they were first claimed, then the I2C speed.
        """
        requests: list[p.Request[Any]] = []
        for _handle, setup in self._claims.values():
            if setup not in requests:  # one set-up for both pins of an encoder
                requests.append(setup)
        if self._i2c is not None:
            requests.append(p.I2CConfig(self._i2c.speed))
        return requests

    # ---- changing (the board and its handles) ------------------------------------------

    def check_free(self, handle: RoleHolder) -> None:
        """Raise unless ``handle`` may take its pin: it is this board's, not released,
        and no other handle holds the pin (:class:`PinRoleError` names the pin and role)."""
        if handle.board is not self._owner:
            raise StaleHandleError(
                repr(handle), f"belongs to another board, not to {self._owner!r}"
            )
        handle.check_usable()
        current = self._claims.get(handle.pin)
        if current is not None and current[0] is not handle:
            raise PinRoleError(handle.pin.name, current[0].ROLE, handle.ROLE)

    def claim(self, handle: RoleHolder, setup: p.Request[Any]) -> Claim | None:
        """Record that ``handle`` holds its pin, set up by ``setup``.

        Done *before* the set-up is sent, so a concurrent claim of the same pin is refused
        at once instead of both reaching the board.  Returns the claim it replaced (the
        handle's own earlier set-up, or None) for :meth:`withdraw` if the board refuses.
        """
        self.check_free(handle)
        previous = self.get(handle.pin)
        self._claims[handle.pin] = (handle, setup)
        return previous

    def withdraw(self, handle: RoleHolder, previous: Claim | None) -> None:
        """Undo :meth:`claim` after its set-up failed: put back ``previous`` (None: free)."""
        current = self._claims.get(handle.pin)
        if current is None or current[0] is not handle:
            return  # released meanwhile: nothing of ours to undo
        if previous is None:
            del self._claims[handle.pin]
        else:
            self._claims[handle.pin] = (previous.handle, previous.setup)

    def amend(self, handle: RoleHolder, setup: p.Request[Any]) -> None:
        """The pin's set-up changed (a level written, a pulse width set): replay ``setup``.

        Ignored unless ``handle`` still holds its pin, so a late reply cannot rewrite the
        record of a role that has ended.
        """
        current = self._claims.get(handle.pin)
        if current is not None and current[0] is handle:
            self._claims[handle.pin] = (handle, setup)

    def release(self, pin: DigitalPin) -> RoleHolder | None:
        """The role of ``pin`` ended: forget it and mark its handle released (returned)."""
        claim = self._claims.pop(pin, None)
        if claim is None:
            return None
        handle = claim[0]
        handle.released = True
        return handle

    def set_i2c(self, bus: I2CHolder) -> None:
        """The I2C bus is on at ``bus.speed`` (A4/A5 are no longer analog inputs)."""
        self._i2c = bus
