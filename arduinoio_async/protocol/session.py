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

*Line noise, retries, loss of sync* are :mod:`._recovery`'s; *probing and framing*
:mod:`._probing`'s; the state both work on, the admission of queued requests and the
way out of the FIFO are :mod:`._session_core`'s.  :class:`Session` puts them together.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from ..errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    ReplyMismatchError,
)
from ._bounds import BOUNDED, TEMPERATURE_RAW_RANGE, possible
from ._constants import Framing
from ._decoder import Decoded, Garbage
from ._exchange import Exchange, LinkStats, Received, SessionState, board_error
from ._framing import LinkFraming, frame_bytes
from ._layout import Frame
from ._messages import ErrorReply, Event, Reply, Request
from ._probing import Probing
from ._recovery import MAX_ATTEMPTS, Recovery
from ._session_core import MAX_IN_FLIGHT, TraceFn
from .commands.misc import (
    ReadCapabilities,
    ReadCapabilitiesReply,
    ReadId,
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
    "TraceFn",
    "board_error",
]

_NOT_A_REPLY = (Garbage, Event)

_FREE_VALUED: dict[type[Request[Any]], bool] = {}


def free_valued(request: type[Request[Any]]) -> bool:
    """Does ``request``'s reply carry values the request does not fix (results, not
    echoes)?  Only such a reply can pass as a one-byte-short slip in CRC-16 framing
    (docs/protocol.md 7.7): an echo the session checks leaves the slip nothing free."""
    free = _FREE_VALUED.get(request)
    if free is None:
        names = {f.name for f in fields(request.REPLY)}  # type: ignore[arg-type]
        free = _FREE_VALUED[request] = bool(names - set(request.ECHO))
    return free


class Session(Recovery, Probing):
    """Pending FIFO, byte window, in-order matching and loss of sync for one link."""

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
            or self._needs_quiet(request)  # held: see receive_data
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
            and not self._needs_quiet(self._flight[0].request)
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
                elif state is SessionState.READY and self._slip_possible(item):
                    # CRC-16's one residual above 1e-9: a reply one byte short (an
                    # inserted byte) passes by chance and ends the read, its displaced
                    # last byte a byte time behind.  Wait for the line to stay quiet.
                    self._held = item
                    out.hold = True
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

    def _slip_possible(self, frame: Frame) -> bool:
        """Could ``frame``, ending a read, be a CRC-valid slip of a free-valued reply?"""
        flight = self._flight
        return isinstance(frame, Reply) and bool(flight) and self._needs_quiet(flight[0].request)

    def _needs_quiet(self, request: Request[Any]) -> bool:
        """Must ``request``'s reply wait one quiet byte time when it ends a read?  In
        CRC-16 framing when free values let a slip through (an identity the session
        expects is fixed like an echo: READ_ID answers the round trips)."""
        return (
            self._crc
            and free_valued(type(request))
            and not (type(request) is ReadId and self.expected_id is not None)
        )

    def release_held(self) -> Received:
        """The line stayed quiet one byte time after a read that ended on a held reply
        (``Received.hold``): no displaced byte followed it, so it is trusted now.  A
        frame held for another reason (bytes left over, a pipelined reply due) keeps
        waiting for the bytes that decide it."""
        out = Received()
        held = self._held
        if (
            held is None
            or self.state is not SessionState.READY
            or self._decoder.buffered
            or self._reply_due_after(held)
        ):
            return out
        self._held = None
        self._dispatch(held, out)
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
