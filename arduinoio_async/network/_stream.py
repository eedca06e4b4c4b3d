"""A remote board as an anyio byte stream: a normal ``Transport`` runs on top of it.

Theory of operation
-------------------
``send()`` splits the bytes into request frames with the protocol's host-side decoder and
issues one Zenoh query per frame, each numbered (a *slot*).  Replies come back on Zenoh's
threads in any order; each is handed to the event loop (never waiting there) and held
until every earlier slot is settled, so ``receive()`` yields reply frames strictly in the
order the requests were sent -- the order the transport's pending queue expects.
Once a transport is attached (:meth:`RemoteByteStream.attach`), settled slots go
straight to it from the callback that settled them: no reader task is woken per reply.
Board-initiated frames (class 0x40) arrive as publications -- the stream samples on this
client's own key, so another client's stream costs it nothing -- and join the same byte
queue as they arrive; the transport's decoder sorts them from the replies as it does on a
serial line.

A slot settles in one of three ways:

* a reply frame (an error reply frame included): its bytes are delivered;
* a *link fault* on the server (its link timed out or lost sync, or it refused the
  request): the server settled this one request, and its outcome is relayed to it alone
  (``Transport.relay_failure``) with the server's exact class where that class says what
  happened to it (``BoardTimeoutError``, ``UsageError``...) and as
  :class:`~arduinoio_async.errors.LinkResyncError` where its fate is unknown (see
  :meth:`RemoteFault.as_error <._keys.RemoteFault.as_error>`).  The other requests in
  flight keep their own slots, so nothing else fails and the client does not resync.
  Before a transport is attached (while waiting for the board) a fault is one byte that
  no frame starts with, which a reader takes for line noise;
* the board is gone (the server answered ``BoardDisconnectedError``, or no server's
  queryable matches the board's key any more): the stream breaks, so the transport fails
  everything with :class:`~arduinoio_async.errors.BoardDisconnectedError`.

"No server" is watched once per stream, not once per query: a Zenoh matching listener on
the querier reports when the last queryable for the board goes (its server closed it,
or the server's session was lost), and a query issued while none matches settles as
"no server answered" at once (Zenoh would drop it unanswered).  A per-query "done"
callback would say the same for each query, but it runs on Zenoh's thread and takes
the interpreter lock while the event loop is handling that query's reply (on this
2-core machine: +22 us per round trip, quartiles 10-44 us, in an A/B of bare gets;
within the noise of ``benchmarks/network_bench.py``'s ``done_callback_cost_us``).  A
query that a server finalises without any reply is therefore a lost reply (the
transport's timeout ends it); ``arduinoio serve`` always answers, with a fault if nothing
else, and Zenoh's own query timeout arrives as an error reply.
"""

from __future__ import annotations

import collections
import logging
from collections.abc import Callable, Mapping
from typing import Any

import anyio
import anyio.abc
import zenoh

from .. import protocol as p
from ..errors import ArduinoIOError
from ..transport import ImmediateSender, LinkAttribute, PushStream, RelayingStream
from ._keys import RemoteFault, decode_fault, events_key, request_key, samples_key, undeclare
from ._loop import LoopHandle, zenoh_callback

__all__ = ["LINK_FAULT_BYTE", "RemoteByteStream"]

log = logging.getLogger(__name__)

#: Stands in for a reply the server could not get: 0x00 starts no frame, and lacks the
#: error flag, so the transport's decoder reports it as garbage at once.
LINK_FAULT_BYTE = b"\x00"
#: Longest a query may wait for its reply; Zenoh then answers it with a timeout error (the
#: transport's own per-request timeout is much shorter and acts first).
QUERY_TIMEOUT = 10.0

_NO_REPLY = RemoteFault("BoardDisconnectedError", "no server answered")
#: Request frames remembered as whole (see ``RemoteByteStream.send_nowait``); past this
#: many distinct frames the memory starts over.
KNOWN_FRAMES = 256


def _matching(status: object) -> bool:
    """A ``MatchingStatus``'s verdict (zenoh's stub types ``matching_status`` as a bool)."""
    return bool(getattr(status, "matching", status))


class _Slot:
    """The reply callback of one query, run on Zenoh's thread; it only schedules."""

    __slots__ = ("_loop", "_number", "_stream")

    def __init__(self, stream: RemoteByteStream, number: int, loop: LoopHandle) -> None:
        self._stream = stream
        self._number = number
        self._loop = loop

    def on_reply(self, reply: zenoh.Reply) -> None:
        sample = reply.ok
        if sample is not None:
            result: bytes | RemoteFault = sample.payload.to_bytes()
        else:
            error = reply.err
            result = decode_fault(error.payload.to_bytes() if error is not None else b"")
        self._loop.call_soon(self._stream._settle, self._number, result)


class RemoteByteStream(anyio.abc.ByteStream, PushStream, ImmediateSender, RelayingStream):
    """The byte stream of board ``board_id`` served somewhere on the Zenoh network."""

    def __init__(
        self,
        session: zenoh.Session,
        board_id: int,
        client_id: str,
        *,
        query_timeout: float = QUERY_TIMEOUT,
    ) -> None:
        self.board_id = board_id
        #: The transport names its link after this.
        self.port = f"zenoh://0x{board_id:04X}"
        self._loop = LoopHandle()
        self._decoder = p.Decoder.from_host()
        # Converted once: a ``bytes`` attachment would be copied into a new ZBytes per query.
        self._attachment = zenoh.ZBytes(client_id.encode())
        self._querier = session.declare_querier(
            request_key(board_id),
            timeout=query_timeout,
            consolidation=zenoh.ConsolidationMode.NONE,
        )
        # Whether some server's queryable answers the board's key; exact at declaration,
        # then kept by the listener (see the module's docstring).
        self._matching = _matching(self._querier.matching_status)
        self._matcher = self._querier.declare_matching_listener(
            self._loop.forward(self._on_matching)
        )
        self._whole_frames: set[bytes] = set()
        self._issued = 0
        self._next = 0
        self._settled: dict[int, bytes | RemoteFault] = {}
        self._chunks: collections.deque[bytes] = collections.deque()
        self._arrived = anyio.Event()
        self._error: anyio.BrokenResourceError | None = None
        self._closed = False
        # Set by attach(): settled bytes go straight to the transport.
        self._on_data: Callable[[bytes], None] | None = None
        self._on_lost: Callable[[BaseException | None], None] | None = None
        self._relay: Callable[[ArduinoIOError], None] | None = None
        #: The server's link faults seen so far (class name and message), for diagnostics.
        self.faults: list[RemoteFault] = []
        self._subscribers = [
            session.declare_subscriber(key, self._loop.forward(self._deliver_event))
            for key in (events_key(board_id), samples_key(board_id, client_id))
        ]

    @property
    def extra_attributes(self) -> Mapping[Any, Callable[[], Any]]:
        """The link's name, ``zenoh://0x0007`` (:class:`LinkAttribute`.port)."""
        return {LinkAttribute.port: lambda: self.port}

    # ---- push mode: the transport's receive path --------------------------------------

    def relay_failures_to(self, relay: Callable[[ArduinoIOError], None]) -> None:
        """Settle a slot the server failed by calling ``relay`` (``Transport.relay_failure``)
        in the slot's turn, once a transport is attached."""
        self._relay = relay

    def attach(
        self, on_data: Callable[[bytes], None], on_lost: Callable[[BaseException | None], None]
    ) -> bool:
        """Deliver received bytes by calling ``on_data`` in the event loop, in order, and
        ``on_lost`` once the stream breaks (the transport's push-mode protocol)."""
        if self._chunks:
            on_data(b"".join(self._chunks))
            self._chunks.clear()
        self._on_data, self._on_lost = on_data, on_lost
        if self._closed or self._error is not None:
            on_lost(self._error)
        return True

    def detach(self) -> None:
        """The transport closed: deliver nothing more to it."""
        self._on_data = self._on_lost = self._relay = None

    # ---- anyio.abc.ByteStream ---------------------------------------------------------

    async def receive(self, max_bytes: int = 65536) -> bytes:
        """The next reply bytes from the server (at most ``max_bytes``); raises the link's
        error once it broke, ``anyio.ClosedResourceError`` once closed."""
        while not self._chunks:
            if self._closed:
                raise anyio.ClosedResourceError
            if self._error is not None:
                raise self._error
            self._arrived = anyio.Event()
            await self._arrived.wait()
        data = self._chunks.popleft()
        while self._chunks and len(data) + len(self._chunks[0]) <= max_bytes:
            data += self._chunks.popleft()
        if len(data) > max_bytes:
            data, rest = data[:max_bytes], data[max_bytes:]
            self._chunks.appendleft(rest)
        return data

    def send_nowait(self, item: bytes) -> None:
        """Issue one query per complete request frame in ``item`` (never suspends)."""
        if self._closed:
            raise anyio.ClosedResourceError
        if self._error is not None:
            raise self._error
        # The transport writes one request frame per call, and a program repeats the same
        # few frames: one seen whole before is sent without decoding it again.
        clean = not self._decoder.buffered  # no earlier bytes of a frame are waiting
        if clean and type(item) is bytes and item in self._whole_frames:
            self._query(item)
            return
        frames = self._decoder.feed(item)
        whole = clean and len(frames) == 1 and not self._decoder.buffered
        if whole and isinstance(frames[0], p.Request) and type(item) is bytes:
            if len(self._whole_frames) >= KNOWN_FRAMES:
                self._whole_frames.clear()
            self._whole_frames.add(item)
        for frame in frames:
            if isinstance(frame, p.Garbage):
                # Only a request can reach the board through a query; a host sends none.
                log.warning("%s: %d bytes are no request, not sent", self.port, len(frame.data))
                continue
            self._query(bytes(item) if whole else frame.encode())

    async def send(self, item: bytes) -> None:
        """Send request bytes to the board: :meth:`send_nowait` (it never suspends)."""
        self.send_nowait(item)

    async def send_eof(self) -> None:
        """Close the stream: a request link has no half-closed state."""
        await self.aclose()

    async def aclose(self) -> None:
        """Stop querying the server and wake a waiting :meth:`receive`; idempotent."""
        if self._closed:
            return
        self._closed = True
        self._arrived.set()
        if self._on_lost is not None:
            self._on_lost(None)
        # Undeclaring waits for running callbacks; ours only schedule, so it is quick.
        for subscriber in self._subscribers:
            undeclare(subscriber)
        undeclare(self._matcher)
        undeclare(self._querier)

    # ---- internals -------------------------------------------------------------------

    def _query(self, frame: bytes) -> None:
        number = self._issued
        self._issued += 1
        if not self._matching:  # Zenoh would drop it unanswered: settle it in its turn
            self._loop.call_soon(self._settle, number, _NO_REPLY)
            return
        try:
            self._querier.get(
                zenoh_callback(_Slot(self, number, self._loop).on_reply),
                payload=frame,
                attachment=self._attachment,
            )
        except zenoh.ZError as exc:
            self._break(f"query failed: {exc}")

    def _on_matching(self, status: zenoh.MatchingStatus) -> None:
        """The listener's news: a server's queryable for the board came or went."""
        self._matching = status.matching
        if not status.matching:
            # The board's last server closed its queryable or was lost: queries in flight
            # will not be answered, so nothing is waited for.
            self._break("no server answers it any more")

    def _settle(self, number: int, result: bytes | RemoteFault) -> None:
        """Record a slot's outcome (the first one wins) and deliver every slot now due."""
        if number == self._next and not self._settled and type(result) is bytes:
            self._next += 1  # the common case: the reply that is due, nothing held back
            self._push(result)
            return
        if number < self._next or number in self._settled:
            return
        self._settled[number] = result
        while self._next in self._settled:
            outcome = self._settled.pop(self._next)
            self._next += 1
            if isinstance(outcome, bytes):
                self._push(outcome)
            elif outcome.disconnected:
                self._break(f"{outcome.message} ({outcome.error} on the server)")
            else:
                self.faults.append(outcome)
                log.info("%s: %s on the server: %s", self.port, outcome.error, outcome.message)
                if self._relay is not None and self._on_data is not None:
                    self._relay(outcome.as_error(self.port))
                else:
                    self._push(LINK_FAULT_BYTE)

    def _deliver_event(self, sample: zenoh.Sample) -> None:
        self._push(sample.payload.to_bytes())

    def _push(self, data: bytes) -> None:
        if self._closed or self._error is not None:
            return
        if self._on_data is not None:
            self._on_data(data)
            return
        self._chunks.append(data)
        self._arrived.set()

    def _break(self, reason: str) -> None:
        if self._error is None and not self._closed:
            self._error = anyio.BrokenResourceError(f"{self.port}: {reason}")
            self._arrived.set()
            if self._on_lost is not None:
                self._on_lost(self._error)
