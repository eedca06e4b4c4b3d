"""The link's state machine without I/O: requests in, bytes out; bytes in, outcomes out.

Theory of operation
-------------------
A :class:`Session` is to the link what h11's ``Connection`` is to HTTP: it never reads a
port, sleeps or wakes a task, so every rule about order and failure lives here and can
be driven directly by a test.  The shell around it (:mod:`arduinoio_async.transport`)
only moves bytes and keeps time.

*Admission.*  :meth:`Session.send` puts every request into one FIFO queue and returns
the bytes that may go on the wire now.  A request leaves the queue only when all earlier
ones have, and only while the board's receive buffer (``window_bytes``) has room, so the
wire order is the call order whatever the number of callers, and a queued request is
never overtaken: it always gets its turn.

*Matching.*  The board answers in order.  A reply is handed to the oldest request in
flight only if it *matches* it (type and every echoed field); an error reply only if it
names the request's tags.  Board-initiated frames (events) never touch the FIFO.

*Line noise.*  Garbage means some reply was damaged.  The session does not give up on
the whole window: it marks the stream *suspect* and sends a marker request behind
everything in flight.  The next valid frame tells where the stream is: if it matches the
k-th request in flight, and no later request could have produced the same frame, the
replies of the k requests before it were lost -- only those fail (with
:class:`ReplyLostError`), the rest of the in-order stream is still verified.  A frame that
could answer several of them (two requests alike in flight) is counted as noise: the one
it answered lost its reply, and the next frame placed settles it with the others before
it.  A frame that matches nothing, a framing error reported by the board or a request
whose deadline passed while in flight make the session *lose sync*: everything in flight
fails, and the shell drains the line and probes the board with an ID request
(:meth:`Session.start_probe`) before the queue moves again.

*Checksum blind spots.*  An 8-bit XOR passes a reply that lost byte ``b`` when the
next frame starts with ``b`` (the candidate steals it), or that gained a byte equal to its
checksum; either way garbage follows the bad frame at once.  So a frame followed by
garbage is not trusted (it counts as noise), and the last frame of a chunk waits for the
next chunk while another reply is due.  A lone request's reply cannot be checked this way:
that residual (about one corrupt frame in 256 faults) is the checksum's, not the session's.
What the checksum passes must still be a reply the board can send: an ID other than
the board's (:attr:`Session.expected_id`, or one a ``WriteId`` in doubt may have set) or a
temperature reading outside what the chip's sensor can report
(:data:`~._bounds.TEMPERATURE_RAW_RANGE`) is noise too, so an idempotent read is asked again
instead of answering with a wrong value.  Docs: ``docs/protocol.md``, "Residual errors".

*Retries.*  A request whose reply was lost is re-sent at the head of the queue -- before
anything queued later -- when it is idempotent (``Request.IDEMPOTENT``), has attempts
left, and no request sent after it could make the repeat observable (a request with side
effects on the same pin, or on no particular pin).  Everything else fails to its caller:
its fate on the board is unknown.  The caller's deadline bounds the retries (the shell
calls :meth:`Session.expire`).

*Board ID.*  A ``WriteId`` whose reply was lost may or may not have changed the ID; the
probe that follows accepts the new ID as well as the old one and adopts what it finds.

*Framing.*  A board whose capabilities (read through the session) announce CRC-16 framing
is switched to it with a ``SetFraming`` barrier, and switched again after a reset drops it
back to XOR framing; the probe decodes both framings to tell.  See
:mod:`~arduinoio_async.protocol._framing`.
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from typing import Any

from ..errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    BoardTimeoutError,
    LinkResyncError,
    ReplyMismatchError,
)
from ._bounds import BOUNDED, TEMPERATURE_RAW_RANGE, possible
from ._constants import RX_FIFO_SIZE, Framing
from ._decoder import Decoded, Decoder, Garbage
from ._exchange import Exchange, LinkStats, Received, SessionState, board_error
from ._framing import MAX_NEGOTIATIONS, LinkFraming, frame_bytes
from ._layout import Frame
from ._messages import ErrorReply, Event, Reply, Request
from .commands.misc import (
    ReadCapabilities,
    ReadCapabilitiesReply,
    ReadId,
    ReadIdReply,
    ResetReply,
)
from .commands.misc import WriteId as _WriteId

__all__ = [
    "MAX_ATTEMPTS",
    "MAX_IN_FLIGHT",
    "TEMPERATURE_RAW_RANGE",
    "Exchange",
    "Framing",
    "LinkStats",
    "Received",
    "Session",
    "SessionState",
    "board_error",
]

#: Requests in flight at once, whatever their size.
MAX_IN_FLIGHT = 64
#: Sends of one idempotent request (the first and the retries).
MAX_ATTEMPTS = 3


TraceFn = Callable[[str, "Decoded"], None]

_NOT_A_REPLY = (Garbage, Event)


class Session:
    """Pending FIFO, byte window, in-order matching and loss of sync for one link."""

    def __init__(
        self,
        *,
        window_bytes: int = RX_FIFO_SIZE,
        max_in_flight: int = MAX_IN_FLIGHT,
        expected_id: int | None = None,
        name: str = "link",
        trace: TraceFn | None = None,
        framing: Framing = Framing.XOR,
    ) -> None:
        self.window_bytes = window_bytes
        self.max_in_flight = max_in_flight
        #: Board ID a probe must find (None: any).
        self.expected_id = expected_id
        self.name = name
        #: Called with ("tx"|"rx", item) for every frame and garbage run.
        self.trace = trace
        self.state = SessionState.READY
        self.stats = LinkStats()
        #: Why the link last lost sync, and the history of reasons (newest last).
        self.last_loss: str | None = None
        self.close_error: BoardDisconnectedError | None = None
        #: The framing in force and wanted (``framing``: used once the board says it can).
        self.framing = LinkFraming(framing)
        self._crc = False
        self._decoder = Decoder.from_board()
        #: While probing: a decoder of the framing not in force (see ``_framing``).
        self._other: Decoder | None = None
        #: A RESET was answered: the next reply comes from a fresh boot (XOR framing).
        self._after_reset = False
        self._queue: collections.deque[Exchange] = collections.deque()
        self._flight: collections.deque[Exchange] = collections.deque()
        self._flight_bytes = 0
        self._suspect = False
        #: Garbage bytes since the last frame that was placed (to place the next one).
        self._noise = 0
        #: The last frame of a chunk, kept until the next chunk vouches for it.
        self._held: Frame | None = None
        self._marker: Exchange | None = None
        self._candidate_ids: set[int] = set()
        self._aligned = True

    # ---- introspection -------------------------------------------------------------------

    @property
    def in_flight(self) -> int:
        return len(self._flight)

    @property
    def in_flight_bytes(self) -> int:
        return self._flight_bytes

    @property
    def queued(self) -> int:
        return len(self._queue)

    def pending(self) -> list[Exchange]:
        """Every exchange not done yet: in flight (oldest first), then queued."""
        return [*self._flight, *self._queue]

    @property
    def aligned(self) -> bool:
        """While draining: the last bytes fed ended on a valid frame's boundary."""
        return self._aligned and not self._decoder.buffered

    # ---- requests ------------------------------------------------------------------------

    def send(self, request: Request[Any]) -> tuple[Exchange, bytes]:
        """Queue ``request``; return its exchange and the bytes to write now (maybe b"")."""
        if self._crc:
            exchange = Exchange(request, frame_bytes(request, True), crc=True)
        else:
            layout = request.LAYOUT
            exchange = Exchange(request, layout.constant or layout.encode(request))
        if self.state is SessionState.CLOSED:
            self._finish(exchange, None, BoardDisconnectedError(str(self.close_error)))
            return exchange, b""
        self.stats.requests += 1
        queue = self._queue
        if (
            not queue
            and self.state is SessionState.READY
            and len(self._flight) < self.max_in_flight
            and (not self._flight or self._flight_bytes + exchange.size <= self.window_bytes)
            and self.framing.negotiation is None
        ):
            # _put_in_flight, inlined: this is every request's path on an idle link.
            exchange.queued = False
            exchange.attempts = 1
            self._flight.append(exchange)
            self._flight_bytes += exchange.size
            if self.trace is not None:
                self.trace("tx", request)
            return exchange, exchange.frame
        queue.append(exchange)
        return exchange, b""

    def cancel(self, exchange: Exchange) -> None:
        """The caller stopped waiting: a queued request is dropped unsent; one in flight
        keeps its place (its reply is consumed in order, then dropped)."""
        if exchange.done:
            return
        if exchange.queued:
            self._queue.remove(exchange)
            exchange.done = True
            return
        exchange.abandoned = True

    def expire(self, exchange: Exchange) -> Received:
        """``exchange``'s deadline passed.  Unsent, it just fails; in flight, the board
        did not answer in time and the session loses sync."""
        out = Received()
        if exchange.done:
            return out
        self.stats.timeouts += 1
        negotiation = self.framing.negotiation
        if exchange.queued and negotiation is not None and not negotiation.queued:
            # It waited behind a SetFraming whose reply never came: the board's framing
            # is unknown, and only a probe can tell.
            self._lose_sync("no reply to SetFraming", out)
        if exchange.queued:
            self._queue.remove(exchange)
            self._finish(
                exchange,
                None,
                BoardTimeoutError(
                    f"{self.name}: {type(exchange.request).__name__} timed out "
                    f"{'before its retry was sent' if exchange.attempts else 'unsent'} "
                    f"(link {self.state}, {len(self._flight)} in flight, "
                    f"{len(self._queue)} queued before it)"
                ),
                out,
            )
            return out
        error = BoardTimeoutError(
            f"{self.name}: no reply to {type(exchange.request).__name__} in time"
        )
        self._lose_sync(f"{type(exchange.request).__name__} timed out", out, exchange, error)
        return out

    def close(self, error: BoardDisconnectedError) -> Received:
        """The port is gone: everything queued or in flight fails with ``error``."""
        out = Received()
        if self.state is SessionState.CLOSED:
            return out
        self.state = SessionState.CLOSED
        self.close_error = error
        self._held = None
        for exchange in [*self._flight, *self._queue]:
            self._finish(exchange, None, BoardDisconnectedError(str(error)), out)
        self._flight.clear()
        self._queue.clear()
        self._flight_bytes = 0
        self._marker = None
        return out

    def relay_failure(self, error: ArduinoIOError) -> Received:
        """The oldest request in flight failed beyond this link, with ``error``.

        For a stream that relays another link (a board served over a network): the far
        end settled the request itself and its replies stay in step with our requests,
        so only this request fails and no resync follows.  Ignored unless the session
        is in sync with a request in flight (it already failed this one itself).
        """
        out = Received()
        held, self._held = self._held, None
        if held is not None and self.state is SessionState.READY:
            self._dispatch(held, out)  # no garbage followed it: the relay came next
        if self.state is SessionState.READY and self._flight and not self._suspect:
            exchange = self._flight.popleft()
            self._flight_bytes -= exchange.size
            if exchange.abandoned or exchange.internal:
                exchange.done = True
            else:
                self._finish(exchange, None, error, out)
            self._admit(out)
        return out

    # ---- bytes from the board ----------------------------------------------------------

    def receive_reply(self, data: bytes) -> Exchange | None:
        """:meth:`receive_data` for the common case only, without building a
        :class:`Received`: when ``data`` is exactly the reply of the one request in flight
        and nothing else is going on (no queue, no noise, no trace), complete that request
        and return its exchange.  Otherwise return None having consumed nothing: pass
        ``data`` to :meth:`receive_data`, which gives the same outcome for this case."""
        flight = self._flight
        if (
            len(flight) != 1
            or self._queue
            or self._held is not None
            or self._suspect
            or self.trace is not None
            or self.state is not SessionState.READY
            or self._after_reset
        ):
            return None
        frame = self._decoder.whole_frame(data)
        exchange = flight[0]
        request = exchange.request
        if (
            type(frame) is not request.REPLY
            or exchange.internal
            or exchange.abandoned
            or type(request) is _WriteId
            or type(frame) is ReadCapabilitiesReply  # may start the framing negotiation
            or type(frame) is ResetReply  # the board boots in XOR framing
        ):
            return None
        if (request.ECHO and not request.matches(frame)) or (
            type(frame) in BOUNDED and not possible(frame, self.expected_id, self._candidate_ids)
        ):
            return None
        flight.popleft()
        self._flight_bytes -= exchange.size
        self.stats.replies += 1
        exchange.done = True
        exchange.reply = frame
        return exchange

    def receive_data(self, data: bytes) -> Received:
        """Feed received bytes; returns completions, events, bytes to write, loss of sync."""
        out = Received()
        trace = self.trace
        if self._other is not None and self.state is SessionState.PROBING:
            return self._probe_both_framings(data, out)
        items = self._decoder.feed(data)
        if trace is not None:
            for item in items:
                trace("rx", item)
        # CRC framing: bytes left over after the last frame that may still become one (a
        # byte displaced by an insertion makes a passing candidate one byte short): the
        # frame waits until they resolve (docs/protocol.md 7.7, "Residual errors").
        trailing = self._crc and self._decoder.buffered > 0
        if (
            trailing
            and self._flight
            and self.state is SessionState.READY
            and LinkFraming.xor_framing_error(self._decoder.peek())
        ):
            # a board that reset answers CRC-framed requests with XOR-framed BAD_CHECKSUM
            # (4 bytes: the CRC decoder waits for a fifth that never comes)
            self._decoder.reset()
            self._lose_sync("the board answers in XOR framing (did it reset?)", out)
            return out
        if self._held is not None:
            items.insert(0, self._held)
            self._held = None
        elif (
            len(items) == 1
            and len(self._flight) == 1
            and self.state is SessionState.READY
            and not trailing
        ):
            # One request in flight and its reply in one chunk (receive_reply's case, with
            # a queue to admit from or an internal, abandoned or WriteId exchange).
            item = items[0]
            request = self._flight[0].request
            if (
                not self._suspect
                and type(item) is request.REPLY
                and (not request.ECHO or request.matches(item))
                and (
                    type(item) not in BOUNDED
                    or possible(item, self.expected_id, self._candidate_ids)
                )
            ):
                self._complete_head(item, None, out)
                if self._queue:
                    self._admit(out)
                return out
        last = len(items) - 1
        for index, item in enumerate(items):
            state = self.state
            if not isinstance(item, _NOT_A_REPLY):
                if index < last:
                    if isinstance(items[index + 1], Garbage):
                        item = Garbage(item.encode())  # not trusted: see _dispatch
                elif state is SessionState.READY and (trailing or self._reply_due_after(item)):
                    # The next reply is on its way: decide when its bytes show whether
                    # garbage follows this frame.
                    self._held = item
                    continue
            if isinstance(item, Event):
                self.stats.events += 1
                out.events.append(item)
                self._aligned = True
            elif state is SessionState.READY:
                self._dispatch(item, out)
            elif state is SessionState.DRAINING:
                self._aligned = not isinstance(item, Garbage)
                if isinstance(item, Garbage):
                    self.stats.garbage_bytes += len(item.data)
            elif state is SessionState.PROBING:
                self._probe_item(item, out)
        if self.state is SessionState.READY and self._queue:
            self._admit(out)
        return out

    def _reply_due_after(self, frame: Frame) -> bool:
        """Is another reply on its way after the one ``frame`` answers?"""
        flight = self._flight
        if len(flight) < 2:
            return False
        if not self._suspect:
            return True  # the frame answers the head
        last = flight[-1].request
        if isinstance(frame, Reply):
            return not last.matches(frame)
        return isinstance(frame, ErrorReply) and not frame.answers(last)

    def _dispatch(self, item: Decoded, out: Received) -> None:
        """Match one frame (a frame followed by garbage arrives here as garbage: an 8-bit
        XOR passes a frame that lost its byte b when the next frame starts with b, or
        that gained a byte equal to its checksum, and either way garbage follows at once;
        so the request fails or is retried instead of getting a wrong answer)."""
        flight = self._flight
        if (
            isinstance(item, Reply)
            and type(item) in BOUNDED
            and not possible(item, self.expected_id, self._candidate_ids)
        ):
            item = Garbage(item.encode())  # a value the board cannot send: noise
        if isinstance(item, Reply):
            if flight and not self._suspect:
                head = flight[0]
                request = head.request
                if type(item) is request.REPLY and (not request.ECHO or request.matches(item)):
                    self._complete_head(item, None, out)
                    return
            self._locate(item, out)
        elif isinstance(item, ErrorReply):
            if item.framing and self._suspect:
                self._noise += item.SIZE  # right after noise, more likely noise than news
            elif item.framing:
                self._lose_sync(f"board reported {item.code.name}", out)
            elif flight and not self._suspect and item.answers(flight[0].request):
                head = flight[0]
                self._complete_head(None, board_error(item, head.request), out)
            else:
                self._locate(item, out)
        else:  # Garbage
            assert isinstance(item, Garbage)
            self.stats.garbage_bytes += len(item.data)
            if not flight:
                return  # noise between replies costs nothing
            if self.framing.negotiation is flight[0]:
                # the board may be in either framing: no marker, a probe tells
                self._lose_sync("SetFraming answered by garbage", out)
                return
            if self._crc and LinkFraming.xor_framing_error(item.data):
                # a board that reset answers CRC-framed requests with XOR-framed
                # BAD_CHECKSUM: no use waiting for a marker it cannot parse
                self._lose_sync("the board answers in XOR framing (did it reset?)", out)
                return
            self._suspect = True
            self._noise += len(item.data)
            if self._marker is None:
                marker = Exchange(
                    ReadCapabilities(),
                    frame_bytes(ReadCapabilities(), self._crc),
                    internal=True,
                    crc=self._crc,
                )
                self._marker = marker
                self._queue.appendleft(marker)
            elif self._marker_reply_lost():
                # More bytes came than every request up to the marker could answer with:
                # the marker's reply was destroyed too, and nothing else can place the
                # replies in flight (status polls' replies cannot be told apart).  Resync
                # now, not at the oldest request's deadline: until then the window fills
                # and the host falls silent (a failsafe's heartbeat with it).
                self._lose_sync("the marker's reply was destroyed", out)

    def _locate(self, item: Reply | ErrorReply, out: Received) -> None:
        """After noise (or a mismatch): which request in flight does ``item`` answer?"""
        flight = self._flight
        matches = [
            index
            for index, exchange in enumerate(flight)
            if (
                exchange.request.matches(item)
                if isinstance(item, Reply)
                else item.answers(exchange.request)
            )
        ]
        if not matches:
            if self._suspect and flight:
                return  # a frame made of noise (1 in 256 passes the checksum): ignore it
            what = type(item).__name__
            if not flight:
                self._lose_sync(f"unsolicited {what}", out)
            else:
                head = flight[0]
                error = ReplyMismatchError(
                    f"{self.name}: {what} does not answer {head.request!r} (got {item!r})"
                )
                self._lose_sync("reply mismatch", out, head, error)
            return
        if len(matches) > 1:
            # The frame may answer a later request whose predecessors all lost replies:
            # keep the positions whose lost replies explain the noise seen.
            matches = [k for k in matches if self._explains_noise(k)]
            if len(matches) != 1:
                # It answers one of several requests and nothing tells which: it counts
                # as noise, so whichever request it answered has lost its reply.  The
                # next frame placed (the marker's at the latest) settles the requests
                # before it; the ones behind stay verified and in sync.
                self.stats.ambiguous += 1
                self._dispatch(Garbage(item.encode()), out)
                return
        retries: list[Exchange] = []
        for _ in range(matches[0]):
            self._lose_head(out, retries)
        self._queue.extendleft(reversed(retries))
        self._suspect = False
        self._noise = 0
        self.stats.resyncs += 1
        if isinstance(item, Reply):
            self._complete_head(item, None, out)
        else:
            self._complete_head(None, board_error(item, flight[0].request), out)

    def _explains_noise(self, k: int) -> bool:
        """Could the replies of the first ``k`` requests in flight have become the garbage
        seen?  A damaged reply of L bytes leaves L - 1 (a byte dropped), L (flipped) or
        L + 1 (one inserted) bytes of garbage; one stray byte more is allowed."""
        low, high = self._noise_bounds(k)
        return low <= self._noise <= high + 1

    def _noise_bounds(self, k: int) -> tuple[int, int]:
        """The fewest and most bytes of garbage the first ``k`` replies can leave."""
        low = high = 0
        for exchange in list(self._flight)[:k]:
            layout = exchange.request.REPLY.LAYOUT
            low += layout.base_size - 1 + self._crc
            high += layout.max_size + 1 + self._crc
        return low, high

    def _marker_reply_lost(self) -> bool:
        """Has more garbage come than the replies up to the marker's could leave?  Replies
        come in order, so the marker's reply is then destroyed, not late."""
        marker = self._marker
        if marker is None or marker.queued:
            return False
        _low, high = self._noise_bounds(self._flight.index(marker) + 1)
        return self._noise > high + 1

    def _complete_head(self, reply: Reply | None, error: BoardError | None, out: Received) -> None:
        exchange = self._flight.popleft()
        self._noise = 0
        self._flight_bytes -= exchange.size
        self.stats.replies += 1
        if exchange is self._marker:
            self._marker = None
            self._suspect = False
            exchange.done = True
            return
        if exchange is self.framing.negotiation:
            self._negotiated(reply, out)
            exchange.done = True
            return
        if type(reply) is ReadCapabilitiesReply:
            self.framing.learn(reply)
            if self.framing.wants_negotiation():
                self._queue.appendleft(self.framing.start_negotiation())
        elif type(reply) is ResetReply:
            # the board boots in XOR framing; once it answers again, switch it back
            self._set_framing(False)
            self._after_reset = True
        elif self._after_reset and reply is not None:
            self._after_reset = False
            if self.framing.wants_negotiation():
                self._queue.appendleft(self.framing.start_negotiation())
        if reply is not None and isinstance(exchange.request, _WriteId):
            self.expected_id = exchange.request.board_id
        if exchange.abandoned:
            self.stats.dropped_late_replies += 1
            exchange.done = True
            return
        exchange.done = True  # _finish, inlined (every reply's path)
        exchange.reply = reply
        exchange.error = error
        out.done.append(exchange)

    def _lose_head(self, out: Received, retries: list[Exchange]) -> None:
        """The oldest request's reply was destroyed by line noise."""
        exchange = self._flight.popleft()
        self._flight_bytes -= exchange.size
        self.stats.lost_replies += 1
        if exchange is self._marker:
            self._marker = None
            exchange.done = True
            return
        self._fail_unknown(
            exchange,
            LinkResyncError(f"{self.name}: line noise destroyed the reply to {exchange.request!r}"),
            list(self._flight),
            out,
            retries,
        )

    def _fail_unknown(
        self,
        exchange: Exchange,
        error: ArduinoIOError,
        later: list[Exchange],
        out: Received,
        retries: list[Exchange],
    ) -> None:
        """``exchange`` may or may not have run: retry it if that is safe, else fail it."""
        if isinstance(exchange.request, _WriteId):
            self._candidate_ids.add(exchange.request.board_id)
        if exchange.abandoned or exchange.internal:
            exchange.done = True
            return
        if self._may_retry(exchange, later):
            exchange.queued = True
            self.stats.retries += 1
            retries.append(exchange)
            return
        self._finish(exchange, None, error, out)

    def _may_retry(self, exchange: Exchange, later: list[Exchange]) -> bool:
        """Sending it again must look like sending it once: every part idempotent, and
        no part's effect observable through a request sent after it.  A transaction's
        items count one by one; two of its own items acting on one pin (or one acting on
        no particular pin beside another) would replay a sequence, so it is not retried."""
        parts = exchange.request.parts()
        if exchange.attempts >= MAX_ATTEMPTS or not all(r.IDEMPOTENT for r in parts):
            return False
        pins = [getattr(r, "pin", None) for r in parts if not r.READS_ONLY]
        if not pins:
            return True
        if len(pins) > 1 and (None in pins or len(set(pins)) != len(pins)):
            return False
        for other in later:
            if other.internal:
                continue
            for part in other.request.parts():
                if part.READS_ONLY:
                    continue
                other_pin = getattr(part, "pin", None)
                if None in pins or other_pin is None or other_pin in pins:
                    return False
        return True

    # ---- losing and regaining sync -------------------------------------------------------

    def _lose_sync(
        self,
        reason: str,
        out: Received,
        blame: Exchange | None = None,
        error: ArduinoIOError | None = None,
    ) -> None:
        if self.state is not SessionState.READY:
            return
        self.last_loss = reason
        out.lost = reason
        self.state = SessionState.DRAINING
        self._aligned = False
        self._held = None
        flight = list(self._flight)
        self._flight.clear()
        self._flight_bytes = 0
        self._suspect = False
        self._noise = 0
        self._marker = None
        negotiation = self.framing.negotiation
        if negotiation is not None and not negotiation.queued:
            self.framing.negotiation = None
            self.framing.failures += 1
        retries: list[Exchange] = []
        for index, exchange in enumerate(flight):
            if exchange is blame and error is not None:
                if isinstance(exchange.request, _WriteId):
                    self._candidate_ids.add(exchange.request.board_id)
                if exchange.abandoned:
                    exchange.done = True
                else:
                    self._finish(exchange, None, error, out)
                continue
            self._fail_unknown(
                exchange,
                LinkResyncError(f"{self.name}: link lost sync ({reason}); request aborted"),
                flight[index + 1 :],
                out,
                retries,
            )
        self._queue.extendleft(reversed(retries))

    def start_probe(self) -> bytes:
        """The line is drained: forget buffered bytes and ask the board for its ID."""
        self._decoder.reset()
        self._other = self.framing.other_decoder()
        self.state = SessionState.PROBING
        probe = ReadId()
        if self.trace is not None:
            self.trace("tx", probe)
        return frame_bytes(probe, self._crc)

    def probe_failed(self, reason: str) -> None:
        """No valid answer in time: drain again."""
        if self.state is SessionState.PROBING:
            self.last_loss = reason
            self.state = SessionState.DRAINING
            self._aligned = False

    def _probe_both_framings(self, data: bytes, out: Received) -> Received:
        """Probing a board that may use either framing.  The framing in force decides
        when it yields the answer; otherwise a framing error about the probe in the other
        framing switches the session to it, and the next probe goes in that framing.  A
        board in the other framing always answers so (the probe's first check byte, 0x03
        or 0x0E, is never the other framing's), and noise cannot forge it: it takes four
        particular bytes that pass the other check.  An ID reply in the other framing is
        not taken as evidence: one inserted byte can make a damaged reply pass it."""
        assert self._other is not None
        other_error = any(LinkFraming.probe_error(item) for item in self._other.feed(data))
        items = self._decoder.feed(data)
        if self.trace is not None:
            for item in items:
                self.trace("rx", item)
        for item in items:
            if isinstance(item, Event):
                self.stats.events += 1
                out.events.append(item)
            elif self.state is SessionState.PROBING:
                self._probe_item(item, out)
            # (after the answer: late replies to requests that failed are skipped)
        if other_error and self.state is not SessionState.READY:
            self._set_framing(not self._crc)
            self.stats.framing_switches += 1
            self.state = SessionState.PROBING  # (probe_failed needs it)
            self.probe_failed(f"probe answered in {self.framing.current.name} framing")
        return out

    def _set_framing(self, crc: bool) -> None:
        """Frames are checked by CRC-16 (``crc``) or XOR from now on, both ways."""
        self._crc = crc
        self.framing.crc = crc
        self._decoder = Decoder.from_board(framing=self.framing.current)
        self._other = None

    def _negotiated(self, reply: Reply | None, out: Received) -> None:
        """The SetFraming barrier's answer arrived (in the new framing: it checked)."""
        self.framing.negotiation = None
        if reply is not None and getattr(reply, "framing", None) is self.framing.current:
            self.framing.failures = 0
            self.stats.framing_switches += 1
            return
        # refused (an error reply that passed the new framing's check): the old framing
        self.framing.failures = MAX_NEGOTIATIONS
        self._set_framing(not self._crc)

    def _probe_item(self, item: Decoded, out: Received) -> None:
        if isinstance(item, ReadIdReply):
            found = item.board_id
            acceptable = self.expected_id is None or found == self.expected_id
            if not acceptable and found in self._candidate_ids:
                acceptable = True
            if not acceptable:
                closed = self.close(
                    BoardDisconnectedError(
                        f"{self.name}: board 0x{self.expected_id:04X} was replaced by a "
                        f"board with ID 0x{found:04X}"
                    )
                )
                out.done.extend(closed.done)
                out.lost = "board replaced"
                return
            if self.expected_id is not None:
                self.expected_id = found
            self._candidate_ids.clear()
            self._other = None
            self.state = SessionState.READY
            if self.framing.wants_negotiation():  # the board reset to XOR framing
                self._queue.appendleft(self.framing.start_negotiation())
            self.stats.resyncs += 1
            self.stats.probes += 1
        elif isinstance(item, Garbage) or (isinstance(item, ErrorReply) and item.framing):
            # What the probe got instead of an answer: no use waiting for the timeout.
            self.probe_failed(f"probe answered by {type(item).__name__}")
        # Late replies to requests that failed when sync was lost are skipped.

    # ---- internals -----------------------------------------------------------------------

    def _admit(self, out: Received) -> None:
        queue = self._queue
        flight = self._flight
        chunks = []
        negotiation = self.framing.negotiation
        while queue:
            exchange = queue[0]
            if negotiation is not None:
                if not negotiation.queued:
                    break  # the barrier is in flight: nothing goes behind it
                if exchange is negotiation:
                    if not self.framing.wants_switch():
                        queue.popleft()  # a probe found the board in that framing already
                        exchange.done = True
                        self.framing.negotiation = negotiation = None
                        continue
                    if flight:
                        break  # it goes alone
                    queue.popleft()
                    self._put_in_flight(exchange)
                    chunks.append(exchange.frame)
                    # the board answers in the framing asked for
                    self._set_framing(self.framing.preferred is Framing.CRC16)
                    break
            if len(flight) >= self.max_in_flight or (
                flight and self._flight_bytes + exchange.size > self.window_bytes
            ):
                break
            queue.popleft()
            self._put_in_flight(exchange)
            chunks.append(exchange.frame)
        if chunks:
            out.outgoing += b"".join(chunks)

    def admit(self) -> bytes:
        """Bytes of queued requests that may go now (after a probe succeeded)."""
        out = Received()
        if self.state is SessionState.READY:
            self._admit(out)
        return out.outgoing

    def _put_in_flight(self, exchange: Exchange) -> None:
        if exchange.crc != self._crc:
            self.framing.reframe(exchange)
        exchange.queued = False
        exchange.attempts += 1
        self._flight.append(exchange)
        self._flight_bytes += exchange.size
        if self.trace is not None:
            self.trace("tx", exchange.request)

    def _finish(
        self,
        exchange: Exchange,
        reply: Reply | None,
        error: ArduinoIOError | None,
        out: Received | None = None,
    ) -> None:
        exchange.done = True
        exchange.reply = reply
        exchange.error = error
        if out is not None:
            out.done.append(exchange)
