"""What a byte stream can do for the transport, declared instead of probed.

Any ``anyio.abc.ByteStream`` carries the protocol: the transport reads with a task and
writes with another.  A stream that can do better says so by *inheriting* the small
interfaces below (anyio's ``abc/_streams.py`` is the model: one ABC per ability, and
typed attributes instead of ``getattr(stream, "port", None)``); the transport looks once,
when it is built (:func:`abilities_of`), and keeps the answer.

* :class:`PushStream`: received bytes are *pushed* to a callback in the event loop
  (``attach``), so a reply is decoded where it arrives, without a task switch.
* :class:`ImmediateSender`: ``send_nowait`` writes (or queues) without suspending, so
  ``request()`` puts its bytes on the wire in call order with no writer task.
* :class:`CollectedWrites`: the sends of one wave of woken callers can be collected into
  one write (``collect_sends``; pipelining).
* :class:`ThreadSafeSender`: another thread may write (``send_from_thread``) while it holds
  the stream's :attr:`~ThreadSafeSender.lock`, which orders its writes with the loop's.
* :class:`RelayingStream`: the stream relays another link (the network client's): its far
  end checks the wire and reports failures the transport must settle in order.

:class:`LinkAttribute` names what a stream may tell about itself (its port's name, its
baud rate) through anyio's ``extra()``.
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import anyio
import anyio.abc

if TYPE_CHECKING:
    from ..errors import ArduinoIOError

__all__ = [
    "Abilities",
    "CollectedWrites",
    "ImmediateSender",
    "LinkAttribute",
    "PushStream",
    "RelayingStream",
    "ThreadSafeSender",
    "abilities_of",
]


class LinkAttribute(anyio.TypedAttributeSet):
    """What a stream tells about its line: ``stream.extra(LinkAttribute.port, "")``."""

    #: The port's name (``/dev/ttyACM0``, a pty, ``zenoh://0x0007``): the link's name.
    port: str = anyio.typed_attribute()
    #: The rate the port was opened at (named when no board answers).
    baudrate: int = anyio.typed_attribute()


class PushStream(ABC):
    """Received bytes delivered by callback in the event loop instead of ``receive()``."""

    @abstractmethod
    def attach(
        self, on_data: Callable[[bytes], None], on_lost: Callable[[BaseException | None], None]
    ) -> bool:
        """From now on call ``on_data`` with received bytes, in order, and ``on_lost`` once
        the line breaks.  False, having done nothing, when this event loop cannot push
        (the transport then reads with ``receive()``)."""

    @abstractmethod
    def detach(self) -> None:
        """Call nothing more (the transport closed; the port may stay open)."""


class ImmediateSender(ABC):
    """Writes without suspending: the bytes are on the wire or queued, in call order."""

    def can_send_nowait(self) -> bool:
        """Whether :meth:`send_nowait` works on this event loop (True unless overridden)."""
        return True

    @abstractmethod
    def send_nowait(self, item: bytes) -> None:
        """Write or queue ``item`` after everything sent before; raises
        ``anyio.BrokenResourceError`` (or ``ClosedResourceError``, ``OSError``) when the
        line is gone."""


class CollectedWrites(ABC):
    """Several sends in one event-loop iteration can go out as one write."""

    @abstractmethod
    def collect_sends(self) -> None:
        """Collect what is sent from now until the loop's queued callbacks have run, then
        write it at once, in the order it was sent."""


class ThreadSafeSender(ABC):
    """Another thread may write while it holds :attr:`lock`."""

    #: Held by whoever decides what goes on the wire next (reentrant: the loop's read
    #: callback holds it while the transport handles the bytes).
    lock: threading.RLock

    @abstractmethod
    def send_from_thread(self, item: bytes) -> bool:
        """Write ``item`` after everything sent before, from a thread that is not the
        loop's, with :attr:`lock` held; False, writing nothing, once the line is gone."""


class RelayingStream(ABC):
    """The stream relays another link, whose far end checks the wire (and frames it)."""

    @abstractmethod
    def relay_failures_to(self, relay: Callable[[ArduinoIOError], None]) -> None:
        """Settle a request the far end failed by calling ``relay``, in its turn."""


@dataclass(frozen=True)
class Abilities:
    """What one stream declared, looked at once (:func:`abilities_of`)."""

    push: PushStream | None
    send_nowait: Callable[[bytes], None] | None
    collect_sends: Callable[[], None] | None
    thread_sender: ThreadSafeSender | None
    relays: bool
    #: The port's name, or "" when the stream does not say.
    port: str
    baudrate: int | None


def abilities_of(stream: anyio.abc.ByteStream) -> Abilities:
    """What ``stream`` declared it can do, and its port's name and baud rate.

    ``send_nowait`` is read here, once: a caller that replaces the stream's method on the
    instance before the transport is built (a test's instrumented write) is what the
    transport writes with.
    """
    nowait = (
        stream.send_nowait
        if isinstance(stream, ImmediateSender) and stream.can_send_nowait()
        else None
    )
    return Abilities(
        push=stream if isinstance(stream, PushStream) else None,
        send_nowait=nowait,
        collect_sends=stream.collect_sends if isinstance(stream, CollectedWrites) else None,
        thread_sender=stream if isinstance(stream, ThreadSafeSender) else None,
        relays=isinstance(stream, RelayingStream),
        port=stream.extra(LinkAttribute.port, ""),
        baudrate=stream.extra(LinkAttribute.baudrate, None),
    )
