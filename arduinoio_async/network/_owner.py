"""The failsafe follows its owner: a served board's watch on the client that armed it.

See :mod:`._served_board` ("The failsafe follows its owner"): when the owner's liveliness
token vanishes or it has sent nothing for the failsafe's timeout, the server stops every
byte to the board until it trips; a vanished client's stream is stopped.
"""

from __future__ import annotations

import logging
import threading

import anyio

from .. import protocol as p
from ..errors import ArduinoIOError
from ..transport import Transport
from ._client_policy import ClientPolicy
from ._host import ServingHost

__all__ = ["STARVE_MARGIN", "STARVE_TICK", "FailsafeOwner"]

log = logging.getLogger(__name__)

#: After the failsafe owner is gone the board is starved this much beyond its timeout at
#: most (a trip report normally ends the starvation sooner).
STARVE_MARGIN = 0.2
#: How often a starving board's heartbeat is held off and its owner's silence is checked.
STARVE_TICK = 0.02


class FailsafeOwner:
    """The owner watch and the starving of a served board (mixed into ServedBoard)."""

    server: ServingHost
    link: Transport
    board_id: int
    closed: bool
    policy: ClientPolicy
    gate: anyio.Event | None
    tripped: anyio.Event
    _lock: threading.Lock

    # ---- the failsafe's owner ----------------------------------------------------------

    def client_gone(self, client: str) -> None:
        """A client's liveliness token vanished: its records and pins go (see
        :meth:`ClientPolicy.client_gone`); the board starves if it owned the failsafe."""
        streamed = self.policy.client_gone(client)
        if client == self.policy.owner and not self.tripped.is_set():
            self._starve(f"client {client} vanished")
        if streamed:
            self.server.start_soon(self._stop_stream_of, client)

    async def _stop_stream_of(self, client: str) -> None:
        """Nobody reads a vanished client's stream: stop it (after any starving)."""
        if self.gate is not None:
            await self.gate.wait()
        try:
            await self.link.request(p.StreamStop())
        except ArduinoIOError as exc:
            log.info("board 0x%04X: stream of %s not stopped: %s", self.board_id, client, exc)
        else:
            log.info(
                "board 0x%04X: stopped the stream of vanished client %s", self.board_id, client
            )

    async def _watch_owner(self, client: str, arm: int) -> None:
        """While ``client`` owns this arming, starve the board once it falls silent."""
        policy = self.policy
        while (
            policy.arms == arm
            and policy.owner == client
            and not self.closed
            and not self.tripped.is_set()
        ):
            silent_for = anyio.current_time() - policy.last_heard.peek(client, 0.0)
            if silent_for > policy.owner_timeout and self.gate is None:
                self._starve(f"client {client} silent for {silent_for * 1000:.0f} ms")
                return
            await anyio.sleep(max(STARVE_TICK, policy.owner_timeout - silent_for))

    def _starve(self, reason: str) -> None:
        if self.gate is not None or self.closed:
            return
        log.warning("board 0x%04X: %s; letting its failsafe trip", self.board_id, reason)
        with self._lock:
            self.gate = anyio.Event()
        self.server.start_soon(self._starve_until_tripped, self.gate)

    async def _starve_until_tripped(self, gate: anyio.Event) -> None:
        give_up = anyio.current_time() + self.policy.owner_timeout + STARVE_MARGIN
        try:
            while not self.tripped.is_set() and anyio.current_time() < give_up:
                # The manager's heartbeat skips a link that sent recently: keep it quiet.
                self.link.last_send = anyio.current_time()
                with anyio.move_on_after(STARVE_TICK):
                    await self.tripped.wait()
            if not self.tripped.is_set():
                log.warning("board 0x%04X: no failsafe trip reported", self.board_id)
        finally:
            self.policy.owner = None
            self.gate = None
            gate.set()
