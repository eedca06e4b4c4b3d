"""What a served board's clients see that differs from the board itself: pure logic.

:class:`~._served_board.ServedBoard` admits queries and keeps them in order; what each
client is *answered* -- where that is not simply the board's reply -- is decided here,
from the request, the client that sent it and the records below, without Zenoh, a loop
or a task (so it is tested on its own, ``tests/network/test_client_policy.py``):

* **Sessions are virtual.**  A client's ``SetSession`` is answered here and recorded
  with the *boot* it was set in (the server's own tag of the real board); its
  ``ReadStatus`` shows it its own tag while that boot lasts and 0 -- a fresh board --
  once the board has reset or been replugged since.  Clients never take each other's
  tags for a reset, and a real reset still reaches every one.
* **The failsafe has an owner.**  The client whose ``FailsafeArm`` went through owns it
  until it disarms (watching the owner is :mod:`._owner`'s job).
* **Board IDs are fixed.**  ``WriteId`` is refused with a ``UsageError``.
* **Pins are held** (:mod:`._pin_holders`) and the sample stream has one client.

The records of a client are bounded and expire (:class:`~._limits.ClientRecords`),
except those of the failsafe's owner, the streaming client and a live client.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Set
from dataclasses import dataclass
from typing import Any

from .. import protocol as p
from ..errors import BoardError, UsageError
from ._limits import ClientRecords
from ._pin_holders import CLAIMS, PinHolders

__all__ = ["LOOP_ONLY", "PER_CLIENT", "WRITE_ID_REFUSED", "ClientPolicy"]

log = logging.getLogger(__name__)

#: Why a remote ``write_id`` is refused (it reaches the client as a UsageError).
WRITE_ID_REFUSED = (
    "board 0x{board:04X}: write_id(0x{new:04X}) is refused over the network: the server, "
    "its clients and the board's keys name the board by its ID, which would change under "
    "them; set the ID on the computer the board is plugged into (arduinoio set-id)"
)
#: Requests whose handling depends on the client that sent them: only for these (and
#: for every request while a client owns the failsafe) the query's attachment is read.
PER_CLIENT: frozenset[type[p.Request[Any]]] = (
    frozenset({p.SetSession, p.ReadStatus, p.FailsafeArm, p.StreamStart}) | CLAIMS
)
#: Requests that always go through the loop: their client matters, or the server answers
#: them itself.
LOOP_ONLY: frozenset[type[p.Request[Any]]] = PER_CLIENT | {p.WriteId}


@dataclass
class _Tag:
    """A client's virtual session tag and the boot of the board it was set in."""

    tag: int
    boot: int | None  # None: set after a reboot the server has not re-tagged yet


class ClientPolicy:
    """The per-client records of one served board and the answers that follow from them.

    ``now`` is the clock the records expire by; ``live_clients`` the clients whose
    liveliness token is up (the server's set, read, never changed here).  ``session``
    arguments are the server's own tag of the real board (``Board.session``).
    """

    def __init__(self, board_id: int, now: Callable[[], float], live_clients: Set[str]) -> None:
        self.board_id = board_id
        self._live = live_clients
        self.stale = False  # the board rebooted and the manager has not re-tagged it yet
        self.owner: str | None = None  # the client whose failsafe is armed
        self.owner_timeout = 0.0
        self.arms = 0  # FailsafeArm requests seen: one owner watch per arming
        self.streamer: str | None = None  # the client whose stream runs (one per board)
        self._streamer_before: str | None = None  # while a StreamStart is on its way
        self.pins = PinHolders()  # which client holds which pin, in which role
        # Bounded and expiring (see ._limits); the failsafe's owner and the streamer stay.
        self.tags = ClientRecords[_Tag](now, self.keeps)
        self.last_heard = ClientRecords[float](now, self.keeps)

    def keeps(self, client: str) -> bool:
        """Whether ``client``'s records stay: owner, streamer, or its liveliness is up."""
        return client in (self.owner, self.streamer) or client in self._live

    def needs_client(self, request: p.Request[Any]) -> bool:
        """Whether the answer to ``request`` depends on who sent it."""
        return self.owner is not None or type(request) in PER_CLIENT

    def answer_locally(self, client: str, request: p.Request[Any], session: int) -> bytes | None:
        """The reply of a request the server answers itself, or None: it goes to the link.

        Raises the refusal the client gets: a UsageError for ``WriteId``, the board's own
        ``PIN_BUSY`` for a pin another live client holds in another role, ``SLOT_BUSY``
        for such a slot.  Records what
        the request claims (a pin, the stream) in arrival order, before the board has it.
        """
        if isinstance(request, p.WriteId):
            raise UsageError(WRITE_ID_REFUSED.format(board=self.board_id, new=request.board_id))
        if isinstance(request, p.SetSession):
            self.tags[client] = _Tag(request.session, None if self.stale else session)
            return p.SetSessionReply(request.session).encode()
        if isinstance(request, p.StreamStart):
            # The stream's samples go to this client from its first sample on: the board
            # sends them after its reply, which may be handled after they are published.
            self._streamer_before, self.streamer = self.streamer, client
        if type(request) in CLAIMS:
            refusal = self.pins.claim(client, request)
            if refusal is not None:  # the client gets a refusal frame like the board's
                code, why = refusal
                log.info("board 0x%04X: refused %r of %s: %s", self.board_id, request, client, why)
                raise BoardError(code, request, why)
        return None

    def refused(self, client: str, request: p.Request[Any]) -> None:
        """The board refused ``request``: undo what was recorded when it was admitted.

        Only a refusal: a request that timed out or lost its reply may have been carried
        out (and the client's retry of an idempotent set-up may already be on its way),
        so its claim stands.
        """
        self.pins.refused(client, request)
        if isinstance(request, p.StreamStart) and self.streamer == client:
            self.streamer = self._streamer_before  # the board kept the stream it had

    def after_link(
        self, client: str, request: p.Request[Any], reply: p.Reply, session: int
    ) -> bytes:
        """The board's reply as ``client`` gets it; the records follow the request (an
        arming makes ``client`` the failsafe's owner and counts in ``arms``)."""
        if isinstance(reply, p.ReadStatusReply):
            return self.virtual_status(client, reply, session).encode()
        if isinstance(request, p.FailsafeArm):
            self.owner, self.owner_timeout = client, request.timeout_ms / 1000
            self.arms += 1
        elif isinstance(request, p.FailsafeDisarm):
            self.owner = None
        elif isinstance(request, p.StreamStop):
            self.streamer = None
        frame: bytes = reply.encode()
        return frame

    def virtual_status(
        self, client: str, raw: p.ReadStatusReply, session: int
    ) -> p.ReadStatusReply:
        """The status as ``client`` must see it: its own tag, or 0 after a reboot."""
        self.stale = raw.session != session
        record = self.tags.get(client)
        if record is None:
            return raw
        if self.stale:
            shown = record.tag if record.boot is None else 0
        elif record.boot is None or record.boot == session:
            record.boot = session
            shown = record.tag
        else:
            shown = 0
        return p.ReadStatusReply(raw.flags, shown)

    def client_gone(self, client: str) -> bool:
        """A client's liveliness token vanished: it holds no pins and no records any more.

        Returns whether its sample stream was running (nobody reads it now: the caller
        stops it).  The failsafe's ownership stays: the board must trip first.
        """
        self.pins.client_gone(client)
        self.tags.pop(client)
        self.last_heard.pop(client)
        if client != self.streamer:
            return False
        self.streamer = None
        return True
