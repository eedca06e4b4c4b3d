"""Message kinds and the command table they register in.

Each message is a frozen dataclass whose annotations are its wire layout (see
``_layout``).  A request names its reply type as its generic parameter, so
``await transport.request(ReadId())`` is typed as returning ``ReadIdReply``.  A reply
*matches* its request when it has the expected type and repeats every field the two have in
common (tags, pin, channel, address...): that is how a client proves a reply belongs to the
request it is waiting for.

The messages themselves live in ``commands``, one module for each command module of
``firmware/src``; they register here when that package is imported (the ``protocol``
package imports it, so the tables below are full whenever ``protocol`` is).  The fields a
reply echoes are declared once, in an :func:`echo` dataclass both the request and its
reply derive from; :func:`reply_frame`, :func:`request_frame` and :func:`event_frame` make
a class a frozen, slotted dataclass with a compiled layout and enter it in the table.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Annotated, Any, ClassVar, Generic, TypeVar, cast, dataclass_transform

from ._constants import ERROR_FLAG, FRAMING_ERRORS, ClassTag, ErrorCode
from ._layout import U8, Frame, frame

__all__ = [
    "EVENT_TYPES",
    "REPLY_TYPES",
    "REQUEST_TYPES",
    "ErrorReply",
    "Event",
    "OnePin",
    "Reply",
    "Request",
    "check_10_bit",
    "echo",
    "event_frame",
    "reply_frame",
    "request_frame",
]


class Reply(Frame):
    """A success reply of the board."""

    __slots__ = ()


class Event(Frame):
    """A frame the board sends without a request (extension, class tag 0x40)."""

    __slots__ = ()


R_co = TypeVar("R_co", bound=Reply, covariant=True)


class Request(Frame, Generic[R_co]):
    """A host request whose success reply has type ``R_co``."""

    __slots__ = ()
    REPLY: ClassVar[type[Reply]]
    #: Field names the reply must repeat; computed when the request is registered.
    ECHO: ClassVar[tuple[str, ...]]
    #: Extension beyond the paper.
    EXTENSION: ClassVar[bool] = False
    #: Sending it twice has the effect of sending it once, so a request whose reply was
    #: lost may be sent again (docs/protocol.md, "Idempotency and retries").
    IDEMPOTENT: ClassVar[bool] = False
    #: It changes nothing on the board (implies IDEMPOTENT).
    READS_ONLY: ClassVar[bool] = False

    def matches(self, reply: Reply) -> bool:
        """True when ``reply`` is this request's reply and echoes what identifies it."""
        if type(reply) is not self.REPLY:
            return False
        return all(getattr(self, name) == getattr(reply, name) for name in self.ECHO)

    def parts(self) -> tuple[Request[Any], ...]:
        """The requests that run on the board when this one is sent: itself, or a
        transaction's items (what the retry rules of ``session`` look at)."""
        return (self,)


REQUEST_TYPES: dict[tuple[int, int], type[Request[Reply]]] = {}
REPLY_TYPES: dict[tuple[int, int], type[Reply]] = {}
EVENT_TYPES: dict[tuple[int, int], type[Event]] = {}

T = TypeVar("T")
Q = TypeVar("Q", bound=type[Request[Any]])
P = TypeVar("P", bound=type[Reply])
E = TypeVar("E", bound=type[Event])


def _message(cls: T) -> T:
    """Messages are values (frozen) and many are built per second (slots)."""
    return cast(T, dataclass(frozen=True, slots=True)(cast(type[Any], cls)))


@dataclass_transform(frozen_default=True)
def echo(cls: type[T]) -> type[T]:
    """Fields a request and its reply share: declared once, inherited by both.

    The reply repeats them, so they are what proves a reply answers its request
    (``Request.ECHO``); a reply adds its results after them, a request its parameters.
    """
    return _message(cls)


@echo
class OnePin:
    """The digital pin a frame is about; a reply echoes it, an event names it."""

    pin: Annotated[int, U8]


@dataclass_transform(frozen_default=True)
def reply_frame(class_tag: ClassTag, descriptor: int) -> Callable[[P], P]:
    """Register a reply under its tags (the tags of the request it answers)."""

    def register(cls: P) -> P:
        cls = _message(cls)
        frame(class_tag, descriptor)(cls)
        REPLY_TYPES[(class_tag, descriptor)] = cls
        return cls

    return register


@dataclass_transform(frozen_default=True)
def event_frame(descriptor: int) -> Callable[[E], E]:
    """Register a board-initiated frame (class tag EVENT)."""

    def register(cls: E) -> E:
        cls = _message(cls)
        frame(ClassTag.EVENT, descriptor)(cls)
        EVENT_TYPES[(ClassTag.EVENT, descriptor)] = cls
        return cls

    return register


@dataclass_transform(frozen_default=True)
def request_frame(
    reply: type[Reply],
    *,
    extension: bool = False,
    idempotent: bool = False,
    reads_only: bool = False,
) -> Callable[[Q], Q]:
    """Register a request under its reply's tags; the echo is the fields both share.

    ``idempotent`` and ``reads_only`` are the retry rules of docs/protocol.md
    ("Idempotency and retries"); a request that only reads is idempotent too.
    """

    def register(cls: Q) -> Q:
        cls = _message(cls)
        layout = reply.LAYOUT
        frame(layout.class_tag, layout.descriptor)(cls)
        cls.REPLY = reply
        reply_names = {f.name for f in fields(reply)}  # type: ignore[arg-type]
        cls.ECHO = tuple(f.name for f in fields(cls) if f.name in reply_names)  # type: ignore[arg-type]
        cls.EXTENSION = extension
        cls.READS_ONLY = reads_only
        cls.IDEMPOTENT = idempotent or reads_only
        REQUEST_TYPES[(layout.class_tag, layout.descriptor)] = cls
        return cls

    return register


def check_10_bit(value: int) -> None:
    """Replies are validated where the range is known: it catches corrupt frames that an
    8-bit XOR checksum lets through (one in 256)."""
    if not 0 <= value <= 0x3FF:
        raise ValueError(f"{value} is not a 10-bit ADC value")


@dataclass(frozen=True, slots=True)
class ErrorReply(Frame):
    """``CT|0x80 DT code CS``: the board refused the request with tags ``CT``/``DT``.

    For bytes the board could not attribute to any request (an unknown class tag) ``DT``
    is 0 and ``class_tag`` is the offending byte without its high bit.
    """

    class_tag: int
    descriptor: int
    code: ErrorCode

    SIZE: ClassVar[int] = 4

    def encode(self) -> bytes:
        """The four bytes on the wire, checksum included (what a board or a fake sends)."""
        body = bytes((ERROR_FLAG | self.class_tag, self.descriptor, self.code))
        return body + bytes((body[0] ^ body[1] ^ body[2],))

    def answers(self, request: Request[Any]) -> bool:
        """True when this error names the tags of ``request``."""
        layout = request.LAYOUT
        return self.class_tag == layout.class_tag and self.descriptor == layout.descriptor

    @property
    def framing(self) -> bool:
        """The board lost the frame boundaries and discards input until the line is quiet."""
        return self.code in FRAMING_ERRORS
