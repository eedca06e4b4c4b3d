"""Regaining a board after the session lost sync: the ID probe, in either framing.

A board whose capabilities (read through the session) announce CRC-16 framing
is switched to it with a ``SetFraming`` barrier, and switched again after a reset drops it
back to XOR framing; the probe decodes both framings to tell.  See
:mod:`~arduinoio_async.protocol._framing`.

While probing, bytes are decoded in both framings (:meth:`Probing._probe_both_framings`):
a framing error about the probe in the other framing switches the session to it.  The
probe's ``ReadId`` answer must name the board expected (or an ID a ``WriteId`` in doubt
may have set, which is adopted); another ID means the board was replaced and the session
closes.  A ``SetFraming`` barrier's answer is handled here too (:meth:`Probing._negotiated`).
"""

from __future__ import annotations

from ..errors import BoardDisconnectedError
from ._decoder import Decoded, Garbage
from ._exchange import Received, SessionState
from ._framing import MAX_NEGOTIATIONS, LinkFraming, frame_bytes
from ._messages import ErrorReply, Event, Reply
from ._session_core import SessionCore
from .commands.misc import ReadId, ReadIdReply

__all__ = ["Probing"]


class Probing(SessionCore):
    """The probe that ends a loss of sync, and the framing it finds (a Session part)."""

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
