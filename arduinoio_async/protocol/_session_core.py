"""The session's state, and the way requests enter and leave the window (no I/O).

:class:`SessionCore` holds what every part of :class:`~.session.Session` works on: the
FIFO of queued requests, the requests in flight and their bytes, the framing, the
statistics.  A request enters the window (:meth:`SessionCore._admit`) only when all
earlier ones have, while the board's receive buffer has room and no ``SetFraming``
barrier is in flight -- the barrier goes alone, and the link switches framing as it
goes -- and it leaves it through :meth:`SessionCore._finish` or :meth:`SessionCore.close`.
"""

from __future__ import annotations

import collections
from collections.abc import Callable

from ..errors import ArduinoIOError, BoardDisconnectedError
from ._constants import RX_FIFO_SIZE, Framing
from ._decoder import Decoded, Decoder
from ._exchange import Exchange, LinkStats, Received, SessionState
from ._framing import LinkFraming
from ._layout import Frame
from ._messages import Reply

__all__ = ["MAX_IN_FLIGHT", "SessionCore", "TraceFn"]

#: Requests in flight at once, whatever their size.
MAX_IN_FLIGHT = 64

TraceFn = Callable[[str, "Decoded"], None]


class SessionCore:
    """The state of one link's session and its admission (see :class:`~.session.Session`)."""

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

    def _set_framing(self, crc: bool) -> None:
        """Frames are checked by CRC-16 (``crc``) or XOR from now on, both ways."""
        self._crc = crc
        self.framing.crc = crc
        self._decoder = Decoder.from_board(framing=self.framing.current)
        self._other = None

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
