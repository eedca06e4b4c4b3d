"""One board on the network: its queryable, its events, its clients' virtual sessions.

Theory of operation
-------------------
Each board the manager has connected gets a queryable for requests, a publisher for its
board-initiated frames and a liveliness token (see :mod:`._keys`); they go when the
manager loses the board and come back when it reconnects.

*The common query never waits for the loop.*  In the Zenoh thread that received it, a
query whose request needs nothing from the loop -- one whose client does not matter and
that the server does not answer itself -- goes on the board's link right there, through
``Transport.request_from_thread``, unless something holds it back: an earlier query
still in the loop's hands, a board being starved, a failsafe owned by a client, a link
resyncing or busy in the loop that moment.  The transport's lock puts it in one order
with the loop's own requests, and the loop hears of it only when its reply has come, to
answer the query (``_answer_exchange``).  This takes the hop into the loop out of the
round trip, the largest cost of serving that is ours (see docs/network.md, "How fast").

Every other query is handed to the event loop and numbered in arrival order; while any
is there, later queries follow it, so nothing overtakes it.  If nothing holds it back (no
earlier query still waiting, the board not being starved) it is answered in the callback
that admitted it: on asyncio the transport's ``request`` coroutine is stepped without a
task (see :class:`~._resumer.Resumer`), so the request reaches the link at once, and the reply goes
back to Zenoh from the callback that completes the request's future.  Otherwise (a
starving board, trio) it goes on to the next free one of a pool of worker tasks, which
takes its query's turn (see ``_take_turn``) and puts the request on the board's one
transport without suspending in between.  Either way requests reach the link in the
order the queries arrived, on any scheduler, and several clients' requests are pipelined
on it like one client's.

What the server changes on the way (everything else passes through untouched) is the
clients' policy, pure logic in :mod:`._client_policy`: sessions are virtual, the
failsafe has an owner, board IDs are fixed, pins are held by their client.  This module
does what follows from it in Zenoh and in tasks:

* **The failsafe follows its owner** (:mod:`._owner`).  When the owner's liveliness
  token vanishes (the process died, the session closed, the lease ran out) or it has
  sent nothing for the failsafe's timeout, the server stops every byte to that board --
  other clients' requests wait, and the manager's heartbeat is held off -- until the
  board trips (or the timeout has passed with a margin).  A dead controller's outputs
  therefore go safe within its timeout, as they would if it had been on the USB cable.
* A vanished client's roles stay configured (outputs hold their levels unless its
  failsafe makes them safe); its sample stream, which nobody reads any more, is stopped.

The server is handed in as a :class:`~._host.ServingHost`: this module does not know
:class:`~._server.BoardServer`, which imports it.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import math
import threading
from collections.abc import Callable
from typing import Any

import anyio
import zenoh
from anyio.streams.memory import MemoryObjectReceiveStream

from .. import protocol as p
from ..board import Board
from ..errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    LinkResyncError,
    ProtocolError,
    UsageError,
)
from ..protocol.session import Exchange
from ..transport import Transport
from ._client_policy import LOOP_ONLY, ClientPolicy
from ._host import ServingHost
from ._keys import (
    announcement_key,
    encode_fault,
    events_key,
    request_key,
    samples_key,
    undeclare,
)
from ._limits import ClientQueues, fair_key, oversized
from ._loop import zenoh_callback
from ._owner import FailsafeOwner
from ._resumer import Resumer

__all__ = ["ServedBoard"]

log = logging.getLogger(__name__)

NOT_ONE_REQUEST = "a query carries one request frame"
#: Queries of one board in progress at once (the transport keeps at most 64 in flight).
WORKERS = 64
#: Request frames remembered with their decoded request (see ``ServedBoard._request_in``);
#: past this many distinct frames the memory starts over.
KNOWN_FRAMES = 256


class ServedBoard(FailsafeOwner):
    """One board on the network: queryable, event publisher, liveliness token."""

    def __init__(self, server: ServingHost, board: Board) -> None:
        self.server = server
        self.board = board
        # The transport is captured now: during a restore the manager detaches the Board
        # from it, but the link itself goes on carrying the clients' requests.
        self.link: Transport = board.link
        self.board_id = board.board_id
        # Parsed once: a key given as a string is parsed and checked on every reply.
        self.key = zenoh.KeyExpr(request_key(self.board_id))
        self.closed = False
        self._samples: tuple[str, zenoh.Publisher] | None = None  # (streamer, publisher)
        self.gate: anyio.Event | None = None  # while the board is being starved
        self.tripped = anyio.Event()
        self._decoder = p.Decoder.from_host()  # the loop's
        self._thread_decoder = p.Decoder.from_host()  # Zenoh's threads', under ``_lock``
        send, receive = anyio.create_memory_object_stream[tuple[int, zenoh.Query]](math.inf)
        self._arrivals = 0  # queries admitted so far: each gets the next number
        self._turn = 0  # number of the last query that went on to the link
        self._turn_waiters = 0
        self._turn_changed = anyio.Event()
        self._admitted = send
        try:  # the fast path steps the transport's coroutine itself: asyncio only
            self._now: Callable[[], float] = asyncio.get_running_loop().time
            self._direct = True
        except RuntimeError:
            self._now = anyio.current_time
            self._direct = False
        self.policy = ClientPolicy(self.board_id, self._now, server.live_clients)
        self._queues = ClientQueues()  # queries in progress and waiting, per client
        self._clients: dict[bytes, str] = {}  # attachments seen, decoded once
        self._requests: dict[bytes, p.Request[Any]] = {}  # frames seen, decoded once
        #: Held by Zenoh's threads from checking that a query may skip the loop until its
        #: request is on the link, and by the loop while it changes what that check reads
        #: (``_in_loop``, ``gate``, ``closed``); never across a wait.
        self._lock = threading.Lock()
        self._in_loop = 0  # queries handed to the loop and not answered yet
        self._loop = server.loop
        server.start_soon(self._run_workers, receive)
        session = server.session
        self._unsubscribe = self.link.subscribe(self._on_event)
        self.publisher = session.declare_publisher(events_key(self.board_id))
        self.queryable = session.declare_queryable(
            self.key, zenoh_callback(self._arrive), complete=True
        )
        self.token = session.liveliness().declare_token(
            announcement_key(self.board_id, str(session.zid()))
        )

    def close(self) -> None:
        if self.closed:
            return
        with self._lock:
            self.closed = True
        self._admitted.close()  # the workers answer what was admitted, then end
        with self._lock:
            for query in self._queues.drain():
                self._refuse(query, self._gone())
        self._unsubscribe()
        for entity in (self.token, self.queryable, self.publisher):
            undeclare(entity)
        if self._samples is not None:
            undeclare(self._samples[1])
        if self.gate is not None:
            self.gate.set()

    # ---- board-initiated frames --------------------------------------------------------

    def _on_event(self, event: p.Event) -> None:
        if isinstance(event, p.FailsafeTripped):
            self.tripped.set()
        publisher = self.publisher
        streamer = self.policy.streamer
        if isinstance(event, p.StreamSample) and streamer:
            publisher = self._samples_publisher(streamer)
        try:
            publisher.put(event.encode())
        except zenoh.ZError as exc:
            log.debug("board 0x%04X: event not published: %s", self.board_id, exc)

    def _samples_publisher(self, client: str) -> zenoh.Publisher:
        """The publisher of the samples of ``client``'s stream (declared once per streamer)."""
        if self._samples is None or self._samples[0] != client:
            if self._samples is not None:
                undeclare(self._samples[1])
            publisher = self.server.session.declare_publisher(samples_key(self.board_id, client))
            self._samples = (client, publisher)
        return self._samples[1]

    # ---- requests --------------------------------------------------------------------

    def _arrive(self, query: zenoh.Query) -> None:
        """In Zenoh's thread: the query's request goes on the link right here if nothing
        holds it back, else the query goes to the loop (see the module docstring).  Too
        large a query is refused; a client's query past its share waits (see ._limits)."""
        too_large = oversized(query)
        if too_large is not None:
            self._refuse(query, ProtocolError(too_large))
            return
        with self._lock:
            admitted = self._queues.admit(fair_key(query, self.server.live_clients), query)
            if admitted is not True:
                if admitted is not False:
                    self._refuse(query, UsageError(admitted))
                return  # False: it waits; ``_reply`` of the client's earlier query admits it
            if self._in_loop == 0 and self.gate is None and self.policy.owner is None:
                request = self._request_in(query, self._thread_decoder)
                if (
                    request is not None
                    and type(request) not in LOOP_ONLY
                    and self._direct
                    and not self.closed
                ):
                    answer = functools.partial(self._answer_exchange, query, request)
                    if self.link.request_from_thread(request, answer):
                        return
            self._in_loop += 1
            self._loop.call_soon(self._admit, query)

    def _answer_exchange(
        self, query: zenoh.Query, request: p.Request[Any], exchange: Exchange
    ) -> None:
        """In the loop: answer a query whose request went on the link from Zenoh's thread."""
        frame = None
        error = exchange.error
        if error is None:
            assert exchange.reply is not None
            try:
                frame = self._after_link("", request, exchange.reply)
            except ArduinoIOError as exc:
                error = exc
        self._reply(query, request, frame, error, looped=False)

    def _admit(self, query: zenoh.Query) -> None:
        """In the loop, in arrival order: number the query; answer it at once if nothing
        holds it back, else hand it to a free worker."""
        self._arrivals += 1
        number = self._arrivals
        if self._direct and self.gate is None and self._turn + 1 == number:
            client, request = self._parse(query)
            # An arming creates anyio objects, which need a task: it takes the worker path.
            if not isinstance(request, p.FailsafeArm):
                self._pass_turn(number)
                self._answer_now(query, client, request)
                return
        try:
            self._admitted.send_nowait((number, query))
        except (anyio.ClosedResourceError, anyio.BrokenResourceError):
            self._reply(query, None, None, self._gone())

    async def _run_workers(
        self, admitted: MemoryObjectReceiveStream[tuple[int, zenoh.Query]]
    ) -> None:
        async with admitted, anyio.create_task_group() as workers:
            for _ in range(WORKERS):
                workers.start_soon(self._work, admitted)

    async def _work(self, admitted: MemoryObjectReceiveStream[tuple[int, zenoh.Query]]) -> None:
        """Answer queries one after another; WORKERS of these pipeline on the link."""
        async for number, query in admitted:
            await self._answer(query, number)

    async def _take_turn(self, number: int) -> None:
        """Return once every query that arrived earlier has had its turn.

        Workers may resume in any order (a worker that just finished can overtake one
        that was woken for an earlier query); the turns restore arrival order.  The caller
        must reach the link without suspending after this returns.
        """
        while self._turn + 1 != number:
            self._turn_waiters += 1
            try:
                await self._turn_changed.wait()
            finally:
                self._turn_waiters -= 1
        self._pass_turn(number)

    def _pass_turn(self, number: int) -> None:
        self._turn = number
        if self._turn_waiters:
            changed, self._turn_changed = self._turn_changed, anyio.Event()
            changed.set()

    def _parse(self, query: zenoh.Query) -> tuple[str, p.Request[Any] | None]:
        """The query's client and its request (None: the payload is not one request).

        The client is read from the attachment only when it matters (``""`` otherwise);
        a frame seen before is not decoded again (requests are immutable).  Both save
        work on every round trip, where the loop (or Zenoh's thread) runs cold.
        """
        request = self._request_in(query, self._decoder)
        if request is None:
            return "", None
        if not self.policy.needs_client(request):
            return "", request
        attachment = query.attachment
        if attachment is None:
            return "", request
        raw = attachment.to_bytes()
        client = self._clients.get(raw)
        if client is None:
            if len(self._clients) >= KNOWN_FRAMES:
                self._clients.clear()
            client = self._clients[raw] = raw.decode(errors="replace")
        return client, request

    def _request_in(self, query: zenoh.Query, decoder: p.Decoder) -> p.Request[Any] | None:
        """The one request in the query's payload (None: not one request), decoded with
        the calling thread's own ``decoder`` unless the frame was seen before."""
        payload = query.payload
        frame = payload.to_bytes() if payload is not None else b""
        request = self._requests.get(frame)
        if request is None:
            frames = decoder.feed(frame)
            decoder.reset()
            if len(frames) != 1 or not isinstance(frames[0], p.Request):
                return None
            request = frames[0]
            if len(self._requests) >= KNOWN_FRAMES:
                self._requests.clear()
            self._requests[frame] = request
        return request

    def _gone(self) -> BoardDisconnectedError:
        return BoardDisconnectedError(f"board 0x{self.board_id:04X} is not connected")

    def _answer_now(self, query: zenoh.Query, client: str, request: p.Request[Any] | None) -> None:
        """The fast path, in the loop callback that admitted the query (asyncio only).

        No worker task is woken: the request goes on the link here, in arrival order by
        construction, and the reply is sent from the callback that completes it (see
        :class:`~._resumer.Resumer`).  Requests the server answers itself complete at once.
        """
        if request is None:
            self._reply(query, None, None, ProtocolError(NOT_ONE_REQUEST))
            return
        if client:
            self.policy.last_heard[client] = self._now()
        try:
            if self.closed:
                raise self._gone()
            local = self.policy.answer_locally(client, request, self.board.session)
        except ArduinoIOError as exc:
            self._reply(query, request, None, exc)
            return
        if local is not None:
            self._reply(query, request, local, None)
            return

        def done(reply: p.Reply | None, error: BaseException | None) -> None:
            frame = None
            if isinstance(error, BoardError):
                self.policy.refused(client, request)
            if reply is not None:
                try:
                    frame = self._after_link(client, request, reply)
                except ArduinoIOError as exc:
                    error = exc
            self._reply(query, request, frame, error)

        Resumer(self.link.request(request), done)

    async def _answer(self, query: zenoh.Query, number: int) -> None:
        """The worker path: for queries that must wait (their turn, a starving board)."""
        frame: bytes | None = None
        error: ArduinoIOError | None = None
        try:
            client, request = self._parse(query)
            if self.gate is not None:  # every query waits while the board is being starved
                await self.gate.wait()
            await self._take_turn(number)
            if request is None:
                error = ProtocolError(NOT_ONE_REQUEST)
            else:
                if client:
                    self.policy.last_heard[client] = self._now()
                try:
                    if self.closed:
                        raise self._gone()
                    frame = self.policy.answer_locally(client, request, self.board.session)
                    if frame is None:
                        try:
                            reply = await self.link.request(request)
                        except BoardError:
                            self.policy.refused(client, request)
                            raise
                        frame = self._after_link(client, request, reply)
                except ArduinoIOError as exc:
                    error = exc
        except BaseException:
            # Cancelled (the server is stopping): the client's stream breaks on this.
            self._reply(query, None, None, self._gone())
            raise
        self._reply(query, request, frame, error)

    def _reply(
        self,
        query: zenoh.Query,
        request: p.Request[Any] | None,
        frame: bytes | None,
        error: BaseException | None,
        *,
        looped: bool = True,
    ) -> None:
        """Answer ``query`` with the reply frame, the board's error reply or a fault;
        ``looped``: the query came through the loop (the count of those goes down).  The
        client's next waiting queries, up to its share, go on in its place."""
        with self._lock:
            if looped:
                self._in_loop -= 1
            for following in self._queues.done(query):
                self._in_loop += 1
                self._loop.call_soon(self._admit, following)
        with query, contextlib.suppress(zenoh.ZError):  # ZError: the session is closing
            if frame is not None:
                query.reply(self.key, frame)
            elif isinstance(error, BoardError) and request is not None:
                layout = request.LAYOUT
                code = p.ErrorCode(error.code)  # type: ignore[arg-type]
                query.reply(
                    self.key, p.ErrorReply(layout.class_tag, layout.descriptor, code).encode()
                )
            elif isinstance(error, ArduinoIOError):
                query.reply_err(encode_fault(error))
            else:
                log.error("board 0x%04X: %r failed: %r", self.board_id, request, error)
                query.reply_err(encode_fault(LinkResyncError(f"server failure: {error!r}")))

    @staticmethod
    def _refuse(query: zenoh.Query, error: ArduinoIOError) -> None:
        with query, contextlib.suppress(zenoh.ZError):  # not counted in progress: no release
            query.reply_err(encode_fault(error))

    def _after_link(self, client: str, request: p.Request[Any], reply: p.Reply) -> bytes:
        """The board's reply as ``client`` gets it (see :meth:`ClientPolicy.after_link`);
        an arming starts the watch on its owner, a disarming clears the trip."""
        frame = self.policy.after_link(client, request, reply, self.board.session)
        if isinstance(request, p.FailsafeArm):
            self.tripped = anyio.Event()
            self.board.failsafe_tripped = False
            self.server.start_soon(self._watch_owner, client, self.policy.arms)
        elif isinstance(request, p.FailsafeDisarm):
            self.board.failsafe_tripped = False
        return frame
