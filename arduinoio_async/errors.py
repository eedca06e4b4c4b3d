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

import dataclasses
import enum
from collections.abc import Callable, Iterable, Sequence

__all__ = [
    "ArduinoIOError",
    "BoardDisconnectedError",
    "BoardError",
    "BoardIdChangedError",
    "BoardNotFoundError",
    "BoardSilentError",
    "BoardTimeoutError",
    "DuplicateBoardError",
    "FailsafeTrippedError",
    "FieldRangeError",
    "FirmwareFeatureError",
    "I2CError",
    "LinkCapacityError",
    "LinkError",
    "LinkResyncError",
    "PinCapabilityError",
    "PinRoleError",
    "PortBusyError",
    "ProtocolError",
    "ReplyMismatchError",
    "StaleHandleError",
    "TimerBusyError",
    "UsageError",
    "ValueRangeError",
    "WatchLostError",
]


class ArduinoIOError(Exception):
    """Base class of every error raised by arduinoio_async."""


# --- local misuse -------------------------------------------------------------------------


class UsageError(ArduinoIOError, ValueError):
    """The request is invalid before it reaches the wire; nothing was sent."""


class PinCapabilityError(UsageError):
    """A pin was asked for a function its board's model (Table III on an Uno) does not give it."""

    def __init__(
        self, pin: str, function: str, capable: Sequence[str], *, number: bool = False
    ) -> None:
        self.pin = pin
        self.function = function
        self.capable = tuple(capable)
        where = f"{function} is available on {', '.join(capable)}"
        if not number:
            super().__init__(f"{pin} cannot do {function}: {where}")
            return
        # A plain number (13 for D13) is the commonest slip: name the pin it meant.
        meant = [name for name in self.capable if name[1:] == pin]
        use = f"use {meant[0]} (from arduinoio_async import {meant[0]})" if meant else where
        super().__init__(f"{pin} is a number, not a pin: {use}")


class PinRoleError(UsageError):
    """A pin already serves one role and was asked for another before being released."""

    def __init__(self, pin: str, current: str, requested: str) -> None:
        self.pin = pin
        self.current = current
        self.requested = requested
        super().__init__(f"{pin} is in use as {current}; release it before using it as {requested}")


class TimerBusyError(PinRoleError):
    """A pin's hardware timer serves another user (docs/motors.md, "Timers and pins").

    Raised before anything is sent; the message names the timer, the other user and its
    pin, e.g. "D9 and D10 share Timer1: D10 is servo PWM, so D9 cannot take duty-cycle PWM
    at 31250 Hz".
    """

    def __init__(self, pin: str, current: str, requested: str, message: str) -> None:
        UsageError.__init__(self, message)
        self.pin = pin
        self.current = current
        self.requested = requested


class StaleHandleError(UsageError):
    """A handle was used where it no longer (or never) speaks for its pin.

    A released handle must not drive a pin another handle may own now, and a handle of
    one board means nothing to another board (the same pin name is a different wire).
    """

    def __init__(self, handle: str, reason: str) -> None:
        self.handle = handle
        self.reason = reason
        super().__init__(f"{handle} {reason}")


class FirmwareFeatureError(UsageError):
    """The board's firmware image does not hold the feature asked for.

    Raised before anything is sent, from the features word of the board's capabilities
    reply.  An Uno image is built for a job (docs: firmware profiles), so the message
    names the images that have the feature and the command that flashes one.
    """

    def __init__(self, board: str, what: str, feature: str, profiles: tuple[str, ...]) -> None:
        self.board = board
        self.what = what
        self.feature = feature
        self.profiles = profiles
        if profiles:
            names = " and ".join(f"'{name}'" for name in profiles)
            image = "image has" if len(profiles) == 1 else "images have"
            hint = f"; the {names} {image} it: arduinoio flash --profile {profiles[0]}"
        else:
            hint = "; no Uno image has it"
        super().__init__(
            f"{board}'s firmware has no {what} (its capabilities lack the {feature} feature){hint}"
        )


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


def describe_request(request: object) -> str:
    """``PwmConfig(pin=D3, pulse_us=1500)``: a request as a user wrote it, enums by name
    (for reprs; messages say it in words, see :func:`request_in_words`)."""
    if not dataclasses.is_dataclass(request) or isinstance(request, type):
        return str(request)
    fields = []
    for item in dataclasses.fields(request):
        value = getattr(request, item.name)
        text = value.name if isinstance(value, enum.Enum) and value.name else repr(value)
        fields.append(f"{item.name}={text}")
    return f"{type(request).__name__}({', '.join(fields)})"


#: Says a request in words.  The words live beside the command table
#: (:mod:`arduinoio_async.protocol.commands.descriptions`), which imports this module and
#: registers itself here when the protocol package is imported, as it is before any request
#: exists; until then a request is said by its repr.
_request_words: Callable[[object], str] = repr


def set_request_words(describe: Callable[[object], str]) -> None:
    """Say requests in words with ``describe`` (the protocol's command table calls it)."""
    global _request_words
    _request_words = describe


def request_in_words(request: object) -> str:
    """ "make D4 a digital output (initially high)": what ``request`` asks, completing "the
    board refused to ..."."""
    return _request_words(request)


def _pin_name(request: object) -> str:
    pin = getattr(request, "pin", None)
    if isinstance(pin, enum.Enum) and pin.name:
        return pin.name
    return f"D{pin}" if isinstance(pin, int) else "the pin"


#: Each error code in words, by name: why the board refused.
_REFUSAL_REASONS = {
    "BAD_CHECKSUM": "the frame's checksum was wrong",
    "UNKNOWN_CLASS": "its firmware does not know this kind of command (older firmware?)",
    "UNKNOWN_DESCRIPTOR": "its firmware does not know this command (older firmware?)",
    "INCOMPLETE_FRAME": "the frame arrived incomplete",
    "RX_OVERFLOW": "its receive buffer overflowed",
    "PIN_NOT_CAPABLE": "the pin cannot do that",
    "PIN_NOT_CONFIGURED": "the pin is not set up for that",
    "PIN_BUSY": "the pin is busy",
    "SLOT_BUSY": "another client of the served board holds that slot",
    "VALUE_OUT_OF_RANGE": "a value is out of range",
    "I2C_NACK_ADDRESS": "no I2C device answered at that address",
    "I2C_NACK_DATA": "the I2C device refused a data byte",
    "I2C_TIMEOUT": "the I2C bus timed out",
    "I2C_STREAMING": "the running stream reads I2C blocks: the bus is the stream's",
    "I2C_NOT_CONFIGURED": "the I2C bus is off",
    "LINK_CAPACITY": "too much for the link",
    "FAILSAFE_TRIPPED": "the failsafe has tripped",
    "EEPROM_FAILED": "its EEPROM did not keep the value",
    "STEPPER_MOVING": "the stepper is moving",
    "NOT_IN_IMAGE": "its firmware image leaves this kind of command out",
    "SPI_NOT_CONFIGURED": "the SPI bridge is off",
    "SPI_MODE_FAULT": "the SPI unit left master mode (D10, the AVR's SS, went low as an input)",
}

#: What a refusal means and what to do about it, by error code name.
_REFUSAL_HINTS = {
    "PIN_BUSY": "{pin} already has another role on the board (given by an earlier command "
    "or program; roles last until released or reset): free it with board.release({pin}) "
    "or `arduinoio release {pin}`, or reset the board with `arduinoio reset`",
    "SLOT_BUSY": "leave the slot out to take a free one, or name another slot",
    "PIN_NOT_CONFIGURED": "{pin} does not have the role this request needs on the board: "
    "configure it first (roles end at every reset of the board)",
    "PIN_NOT_CAPABLE": "Table III of the paper lists what each pin can do",
    "FAILSAFE_TRIPPED": "it holds the outputs in their safe states: re-arm it "
    "(board.rearm_failsafe()) or clear it with `arduinoio failsafe --clear`",
    "I2C_NACK_ADDRESS": "is a device at that address, and powered?",
    "I2C_TIMEOUT": "SDA/SCL held low? pull-ups?",
    "I2C_STREAMING": "read the device through the stream's blocks, or stop the stream first",
    "NOT_IN_IMAGE": "each Uno image is built for a job (docs: firmware profiles); "
    "flash one that has it with `arduinoio flash --profile NAME`",
    "I2C_NOT_CONFIGURED": "configure the I2C bus first (board.i2c())",
    "STEPPER_MOVING": "stop it and wait until it rests (await stepper.stop(); "
    "await stepper.wait())",
    "SPI_NOT_CONFIGURED": "set the SPI bridge up first (board.spi(cs=...))",
    "SPI_MODE_FAULT": "make D10 the chip select or an output while SPI is in use",
}


class BoardError(ArduinoIOError):
    """The board answered a request with an error reply.

    ``code`` is the protocol's :class:`~arduinoio_async.protocol.ErrorCode`; ``request`` the
    request that was refused.  The message says in words what was asked, why the board
    refused it and how to get past it (code inspects ``code``, not the text).
    """

    def __init__(self, code: object, request: object, detail: str = "") -> None:
        self.code = code
        self.request = request
        name = str(getattr(code, "name", code))
        hint = _REFUSAL_HINTS.get(name, "").format(pin=_pin_name(request))
        reason = _REFUSAL_REASONS.get(name, f"error {name}")
        text = f"board refused to {request_in_words(request)}: {reason}"
        extra = "; ".join(part for part in (hint, detail) if part)
        super().__init__(f"{text} ({extra})" if extra else text)


class I2CError(BoardError):
    """The I2C bridge reported a NACK, a bus timeout or that the bus is not configured."""


class LinkCapacityError(BoardError):
    """A stream was refused because its frames would not fit the link's byte rate.

    ``min_period_us`` is the shortest period the board admits for the same channels at
    ``baud`` (None when the raiser did not know the board's baud).
    """

    def __init__(
        self,
        code: object,
        request: object,
        detail: str = "",
        *,
        min_period_us: int | None = None,
        baud: int | None = None,
    ) -> None:
        self.min_period_us = min_period_us
        self.baud = baud
        if min_period_us is not None and not detail:
            detail = (
                f"the link cannot carry these samples that often: the shortest period for "
                f"these channels at {baud} baud is {min_period_us / 1000:g} ms"
            )
        super().__init__(code, request, detail)


class FailsafeTrippedError(BoardError):
    """The link watchdog fired; outputs are in their safe states until it is re-armed."""


class WatchLostError(ArduinoIOError):
    """A watch (change events, counter reports, analog moves) was not restored after the
    board reset, so no further event will come: its iterator ends with this error.

    ``request`` is the watch request the restore sent; ``reason`` says why it failed (the
    board's refusal: the pin has another role now, or none).
    """

    def __init__(self, request: object, reason: str) -> None:
        self.request = request
        self.reason = reason
        super().__init__(
            f"the board reset and the request to {request_in_words(request)} could not be "
            f"restored: {reason}"
        )


# --- the link failed ------------------------------------------------------------------------


class LinkError(ArduinoIOError):
    """The request's fate on the board is unknown because the link failed."""


class BoardTimeoutError(LinkError, TimeoutError):
    """No reply arrived within the request's timeout."""


#: Replies of an STK500 bootloader (optiboot, avrdude's ``-c arduino``): STK_INSYNC then
#: STK_OK, or STK_NOSYNC.
_STK500_REPLIES = (b"\x14\x10", b"\x15")
_EITHER = (
    "either the baud rate is wrong (this firmware runs at 115200, 1000000 or 2000000 baud: "
    "try --baud) or the board {runs} (`arduinoio flash` installs this firmware)"
)


class BoardSilentError(BoardTimeoutError):
    """A board did not answer the ID requests sent while waiting for it to boot.

    ``heard`` is what arrived instead (the first bytes), ``baudrate`` the rate the port
    was opened at, ``bootloader`` what a look at the board's bootloader found (None: not
    looked or no answer; "empty": the application flash is erased; "program": it holds
    one).  The message names the likely causes these tell apart: silence is a wrong baud
    rate or no firmware; STK500 replies, or an erased flash behind the bootloader, are a
    board that runs only its bootloader.
    """

    def __init__(
        self,
        port: str,
        heard: bytes,
        *,
        baudrate: int | None = None,
        bootloader: str | None = None,
    ) -> None:
        self.port = port
        self.heard = bytes(heard)
        self.baudrate = baudrate
        self.bootloader = bootloader
        at = f" at {baudrate} baud" if baudrate else ""
        sent = f"it sent {self.heard[:16].hex(' ')}" if heard else f"it sent nothing{at}"
        if bootloader == "empty":
            why = (
                "this board runs a bootloader only (the bootloader answers, the application "
                "flash is empty): install the firmware with `arduinoio flash`"
            )
        elif any(reply in self.heard for reply in _STK500_REPLIES):
            why = (
                f"{sent}, bootloader (STK500) replies: this board runs a bootloader only; "
                "install the firmware with `arduinoio flash`"
            )
        elif bootloader == "program":
            why = f"{sent}, but its bootloader says it holds a program; "
            why += _EITHER.format(runs="runs other firmware")
        elif heard:
            why = f"{sent}, which is no reply of this firmware; "
            why += _EITHER.format(runs="runs other firmware")
        else:
            why = f"{sent}; " + _EITHER.format(runs="has no firmware yet")
        super().__init__(f"{port} did not answer an ID request: {why}")


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


class BoardIdChangedError(BoardDisconnectedError):
    """The board on a link answers with another ID than the one it was known by.

    Its ID was rewritten behind the library's back (a raw ``WriteId``, another program):
    by the library's rule -- a board is its ID -- it is another board now, so the old
    board's pin roles, watches and failsafe are not replayed on it.
    """

    def __init__(self, port: str, old_id: int, new_id: int) -> None:
        self.port = port
        self.old_id = old_id
        self.new_id = new_id
        super().__init__(
            f"{port}: board 0x{old_id:04X} now answers as 0x{new_id:04X}; "
            f"not restored under its old ID"
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
        ports = "; ".join(f"{p}: {why}" for p, why in sorted(tried.items()))
        if not ports:
            super().__init__(
                f"no board with ID 0x{board_id:04X} found: there are no candidate ports "
                "(plug in an Uno or start a virtual one with `arduinoio sim`, or name ports: "
                "BoardManager(ports=..., patterns=...), "
                "--ports PATH_OR_GLOB on the command line, or ARDUINOIO_PORTS)"
            )
            return
        super().__init__(f"no board with ID 0x{board_id:04X} found (tried {ports})")


class DuplicateBoardError(ArduinoIOError):
    """Two ports answered with the same board ID, so the ID cannot name one board."""

    def __init__(self, board_id: int, ports: Iterable[str]) -> None:
        self.board_id = board_id
        self.ports = tuple(sorted(ports))
        super().__init__(
            f"board ID 0x{board_id:04X} is answered by more than one port: {', '.join(self.ports)}"
        )
