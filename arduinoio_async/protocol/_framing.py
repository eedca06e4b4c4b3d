"""Which framing a link's frames use, and how a session negotiates and recovers it.

Theory of operation
-------------------
Every boot of the board starts in the paper's framing (one XOR byte, ``Framing.XOR``).  A
board whose capabilities announce ``Feature.CRC16`` switches to CRC-16 framing when it
receives ``SetFraming(CRC16)``, and answers that request already in the new framing, so a
reply that passes its CRC and echoes the mode proves the switch.  The session sends it
itself, as a *barrier*: only with nothing in flight, and nothing is admitted behind it
until its reply is in (the framing changes between two requests, never inside a
pipeline).  Requests queued meanwhile are framed again when they go out.

What can go wrong, and what the session does:

* the board has old firmware: no feature bit, no ``SetFraming``; the link stays in XOR;
* the reply is lost or garbled: the board's framing is unknown, the session loses sync,
  and the probe finds out (below);
* the board resets mid-session (back to XOR): the host's CRC-framed requests get XOR
  framing errors, the session loses sync, the probe finds out, the link goes on in XOR and
  negotiates again;
* noise: a probe answer in the other framing must be an *answer to the probe* (the board's
  ID, or an error naming the probe's tags), so a few noise bytes that happen to pass the
  other framing's check cannot switch the link.

The probe (an ID request, sent in the framing the session believes in) is decoded in both
framings while the board is one that may switch (:meth:`LinkFraming.other_decoder`).  An
answer in the other framing switches the session's framing; a ``ReadIdReply`` there
completes the probe, an error reply there (the board could not parse a probe framed the
other way) makes the next probe go out in the framing the board uses.
"""

from __future__ import annotations

from typing import Any

from ._constants import ClassTag, Feature, Framing
from ._decoder import Decoder
from ._exchange import Exchange
from ._layout import crc_framed
from ._messages import ErrorReply, Request
from .commands.misc import ReadCapabilitiesReply, ReadId, SetFraming

__all__ = ["MAX_NEGOTIATIONS", "LinkFraming", "frame_bytes"]

#: Consecutive failed negotiations after which a session stays in XOR framing.
MAX_NEGOTIATIONS = 3


def frame_bytes(request: Request[Any], crc: bool) -> bytes:
    """``request`` on the wire, in XOR or CRC-16 framing."""
    layout = request.LAYOUT
    if crc:
        return layout.crc_constant or crc_framed(layout.encode(request))
    return layout.constant or layout.encode(request)


class LinkFraming:
    """The framing in force, the one wanted, and the negotiation in progress."""

    __slots__ = ("capable", "crc", "failures", "negotiation", "preferred")

    def __init__(self, preferred: Framing) -> None:
        #: Frames are CRC-16 framed now (both ways).
        self.crc = False
        self.preferred = preferred
        #: The board announced Feature.CRC16 (so it may be in either framing).
        self.capable = False
        #: The SetFraming barrier, queued or in flight.
        self.negotiation: Exchange | None = None
        #: Negotiations that failed in a row.
        self.failures = 0

    @property
    def current(self) -> Framing:
        return Framing.CRC16 if self.crc else Framing.XOR

    def reframe(self, exchange: Exchange) -> None:
        """Frame ``exchange`` in the framing in force (it was queued across a switch)."""
        if exchange.crc != self.crc:
            exchange.frame = frame_bytes(exchange.request, self.crc)
            exchange.size = len(exchange.frame)
            exchange.crc = self.crc

    def learn(self, reply: ReadCapabilitiesReply) -> None:
        """The board's capabilities passed by: can it switch framing?"""
        self.capable = bool(reply.features & Feature.CRC16)

    def wants_switch(self) -> bool:
        """Switching to the preferred framing is wanted, possible and not done (a board
        in CRC framing can switch: an earlier program may have left it there)."""
        return (
            (self.capable or self.crc)
            and self.current is not self.preferred
            and self.failures < MAX_NEGOTIATIONS
        )

    def wants_negotiation(self) -> bool:
        return self.negotiation is None and self.wants_switch()

    def start_negotiation(self) -> Exchange:
        """The barrier exchange: ``SetFraming(preferred)``, framed when it goes out."""
        request = SetFraming(self.preferred)
        exchange = Exchange(request, frame_bytes(request, self.crc), internal=True, crc=self.crc)
        self.negotiation = exchange
        return exchange

    def other_decoder(self) -> Decoder:
        """For a probe: a decoder of the framing not in force.  Always: before its
        capabilities are read, a board may still be in the framing an earlier program
        left it in (an old firmware's XOR frames never pass as CRC-16 answers)."""
        return Decoder.from_board(framing=Framing.XOR if self.crc else Framing.CRC16)

    @staticmethod
    def probe_error(item: object) -> bool:
        """A framing error reply about the ID probe (``01 02``): a board that could not
        parse the probe in the framing it was sent in (BAD_CHECKSUM for ``01 02``, or
        UNKNOWN_CLASS naming the 0x01 it could not place)."""
        return (
            isinstance(item, ErrorReply)
            and item.framing
            and item.class_tag == ClassTag.MISC
            and item.descriptor in (0, ReadId.LAYOUT.descriptor)
        )

    @staticmethod
    def xor_framing_error(garbage: bytes) -> bool:
        """``garbage`` (seen in CRC framing) holds an XOR-framed framing error reply."""
        return any(
            isinstance(item, ErrorReply) and item.framing
            for item in Decoder.from_board().feed(garbage)
        )
