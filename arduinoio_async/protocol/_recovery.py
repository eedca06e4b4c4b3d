"""Line noise, retries and loss of sync: what the session does when a reply goes wrong.

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

*Retries.*  A request whose reply was lost is re-sent at the head of the queue -- before
anything queued later -- when it is idempotent (``Request.IDEMPOTENT``), has attempts
left, and no request sent after it could make the repeat observable (a request with side
effects on the same pin, or on no particular pin).  Everything else fails to its caller:
its fate on the board is unknown.  The caller's deadline bounds the retries (the shell
calls :meth:`Session.expire`).

*Board ID.*  A ``WriteId`` whose reply was lost may or may not have changed the ID; the
probe that follows accepts the new ID as well as the old one and adopts what it finds.
"""

from __future__ import annotations

from ..errors import ArduinoIOError, BoardTimeoutError, LinkResyncError
from ._exchange import Exchange, Received, SessionState
from ._session_core import SessionCore
from .commands.misc import WriteId as _WriteId

__all__ = ["MAX_ATTEMPTS", "Recovery"]

#: Sends of one idempotent request (the first and the retries).
MAX_ATTEMPTS = 3


class Recovery(SessionCore):
    """Lost replies, retries, deadlines and the loss of sync (a Session part)."""

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
