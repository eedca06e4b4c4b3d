"""Every exception the library raises, rooted in :class:`ArduinoIOError`.

The tree separates three kinds of failure so that callers can react precisely:

* *usage errors* (``UsageError``): the caller asked for something Table III or the value
  ranges forbid; nothing was sent, retrying will not help;
* *board errors* (``BoardError``): the board received a well-formed request and refused it
  with an error reply; the link is healthy;
* *link errors* (``LinkError``): the request may or may not have run on the board because
  the link timed out, was corrupted or went away.

Each class builds its own message from structured attributes, so code can inspect the
attributes instead of parsing strings.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

__all__ = [
    "ArduinoIOError",
    "BoardDisconnectedError",
    "BoardError",
    "BoardNotFoundError",
    "BoardTimeoutError",
    "DuplicateBoardError",
    "FailsafeTrippedError",
    "FieldRangeError",
    "I2CError",
    "LinkCapacityError",
    "LinkError",
    "LinkResyncError",
    "PinCapabilityError",
    "PinRoleError",
    "ProtocolError",
    "ReplyMismatchError",
    "UsageError",
    "ValueRangeError",
]


class ArduinoIOError(Exception):
    """Base class of every error raised by arduinoio_async."""


# --- local misuse -------------------------------------------------------------------------


class UsageError(ArduinoIOError, ValueError):
    """The request is invalid before it reaches the wire; nothing was sent."""


class PinCapabilityError(UsageError):
    """A pin was asked for a function that Table III does not give it."""

    def __init__(self, pin: str, function: str, capable: Sequence[str]) -> None:
        self.pin = pin
        self.function = function
        self.capable = tuple(capable)
        super().__init__(
            f"{pin} cannot do {function}: {function} is available on {', '.join(capable)}"
        )


class PinRoleError(UsageError):
    """A pin already serves one role and was asked for another before being released."""

    def __init__(self, pin: str, current: str, requested: str) -> None:
        self.pin = pin
        self.current = current
        self.requested = requested
        super().__init__(f"{pin} is in use as {current}; release it before using it as {requested}")


class ValueRangeError(UsageError):
    """A value lies outside the range the board accepts."""

    def __init__(self, what: str, value: object, allowed: str) -> None:
        self.what = what
        self.value = value
        self.allowed = allowed
        super().__init__(f"{what} {value!r} is out of range: {allowed}")


class FieldRangeError(UsageError):
    """A message field does not fit its wire type (for example 300 in a byte)."""


# --- the peer sent something wrong ---------------------------------------------------------


class ProtocolError(ArduinoIOError):
    """The bytes from the peer broke the protocol."""


# --- the board refused a request ------------------------------------------------------------


class BoardError(ArduinoIOError):
    """The board answered a request with an error reply.

    ``code`` is the protocol's :class:`~arduinoio_async.protocol.ErrorCode`; ``request`` the
    request that was refused.
    """

    def __init__(self, code: object, request: object, detail: str = "") -> None:
        self.code = code
        self.request = request
        text = f"board refused {request!r}: {getattr(code, 'name', code)}"
        super().__init__(f"{text} ({detail})" if detail else text)


class I2CError(BoardError):
    """The I2C bridge reported a NACK, a bus timeout or that the bus is not configured."""


class LinkCapacityError(BoardError):
    """A stream was refused because its frames would not fit the link's byte rate."""


class FailsafeTrippedError(BoardError):
    """The link watchdog fired; outputs are in their safe states until it is re-armed."""


# --- the link failed ------------------------------------------------------------------------


class LinkError(ArduinoIOError):
    """The request's fate on the board is unknown because the link failed."""


class BoardTimeoutError(LinkError, TimeoutError):
    """No reply arrived within the request's timeout."""


class BoardDisconnectedError(LinkError, ConnectionError):
    """The port was closed or lost; pending and new requests fail at once."""


class PortBusyError(BoardDisconnectedError):
    """The port is held open by another process (opened exclusively); nothing was sent.

    Discovery skips such ports instead of stealing another program's replies.
    """

    def __init__(self, port: str, detail: str = "") -> None:
        self.port = port
        self.detail = detail
        super().__init__(
            f"port {port} is in use by another process" + (f" ({detail})" if detail else "")
        )


class LinkResyncError(LinkError):
    """The request was in flight when the link lost sync and had to be resynchronised."""


class ReplyMismatchError(LinkResyncError):
    """A reply did not echo what its request sent; it was not delivered to anyone."""


# --- discovery ------------------------------------------------------------------------------


class BoardNotFoundError(ArduinoIOError, LookupError):
    """No board with the requested ID answered; ``tried`` maps each port to what it said."""

    def __init__(self, board_id: int, tried: dict[str, str]) -> None:
        self.board_id = board_id
        self.tried = dict(tried)
        ports = "; ".join(f"{p}: {why}" for p, why in sorted(tried.items())) or "no ports found"
        super().__init__(f"no board with ID 0x{board_id:04X} found (tried {ports})")


class DuplicateBoardError(ArduinoIOError):
    """Two ports answered with the same board ID, so the ID cannot name one board."""

    def __init__(self, board_id: int, ports: Iterable[str]) -> None:
        self.board_id = board_id
        self.ports = tuple(sorted(ports))
        super().__init__(
            f"board ID 0x{board_id:04X} is answered by more than one port: {', '.join(self.ports)}"
        )
