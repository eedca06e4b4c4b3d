"""What one client may cost a served board: input sizes, queries in progress, records kept.

The server meets clients it cannot trust to be well behaved: a bug in a program, a
runaway loop, a hostile peer on the network.  Each limit here keeps one such client from
costing the others more than its share (``benchmarks/network_attacks.py`` measures a
legitimate client's latency under each attack):

* **Sizes, before anything is decoded.**  A query's payload is one request frame (at most
  :data:`MAX_PAYLOAD` bytes, twice the longest request frame) and its attachment a client
  ID (at most :data:`MAX_ATTACHMENT` bytes); a longer one is refused from its length
  alone, in Zenoh's thread, with a ``ProtocolError`` to its sender.  (A 1 MB payload used
  to be decoded byte by byte under the board's lock: 2.5 s in which every other client
  waited.)
* **Queries in progress, per client.**  A client (its attachment, if its liveliness
  token is up; all other queries -- no attachment, or a made-up one -- share one client)
  has at most :data:`CLIENT_QUERIES` queries on their way to the board at once, and
  while other clients are active (a query of theirs on the board, or one in the last
  :data:`ACTIVE_WINDOW` seconds) an equal part of them (``CLIENT_QUERIES // active``, at least
  :data:`MIN_SHARE`); later ones wait in the client's own queue, in order, and go on as
  its earlier ones are answered.  So a client flooding the server holds at most that many
  places ahead of anyone else's request, whatever it sends -- half of them while one other
  client calls, so a control loop calling one request after another waits behind 8 of the
  flood's requests, not 16, each time -- and a library client (64 requests in flight at
  most) is slowed, never refused.  Past :data:`CLIENT_BACKLOG` waiting queries
  of one client, or :data:`SERVER_BACKLOG` for the whole board, a query is refused with a
  ``UsageError`` (it was not sent to the board).
* **Records per client, bounded and expiring.**  The virtual session tags and the times
  a client was last heard (:class:`ClientRecords`) hold at most :data:`CLIENT_RECORDS`
  clients, the least recently used going first, and forget a client not heard from for
  :data:`CLIENT_EXPIRY` seconds.  Never forgotten: the failsafe's owner, the streaming
  client, and a client whose liveliness token is up (the library's clients declare one;
  the server tracks :data:`LIVE_CLIENTS` of them), so a flood of made-up attachments
  pushes out only other made-up ones.  A forgotten client's next status poll shows it a
  fresh board (session 0): it restores its pin roles, as after a reset, and sets its tag
  again.

The attachment is whatever the client declares; only a client that also holds a liveliness
token gets a share of its own, so a peer inventing a new attachment per query shares one
share with every other such query.  A peer that declares tokens too gets a share per
token (the server tracks at most ``LIVE_CLIENTS``): keeping such peers off the network is
the job of Zenoh's access control (docs/network.md).
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable, Iterator, Set
from typing import Generic, TypeVar

import zenoh

from .. import protocol as p

__all__ = [
    "ACTIVE_WINDOW",
    "CLIENT_BACKLOG",
    "CLIENT_EXPIRY",
    "CLIENT_QUERIES",
    "CLIENT_RECORDS",
    "LIVE_CLIENTS",
    "MAX_ATTACHMENT",
    "MAX_PAYLOAD",
    "MIN_SHARE",
    "SERVER_BACKLOG",
    "ClientQueues",
    "ClientRecords",
    "oversized",
]

#: Bytes of a query's payload at most: twice the longest request frame (room for a
#: framing with a longer check, never room for a costly decode).
MAX_PAYLOAD = 2 * max(request.LAYOUT.max_size for request in p.REQUEST_TYPES.values())
#: Bytes of a query's attachment (the client's ID: 32 hex digits from the library).
MAX_ATTACHMENT = 64
#: Queries of one client on their way to the board at once; later ones wait their turn.
CLIENT_QUERIES = 16
#: Queries of one client on the board at once while others are active, at least (keeps
#: a client's requests pipelined on the link).
MIN_SHARE = 2
#: Seconds after its last query during which a client counts as active (a control loop at
#: 10 Hz and up is active all the time).
ACTIVE_WINDOW = 0.1
#: Queries of one client waiting their turn at most; past this a query is refused.
CLIENT_BACKLOG = 256
#: Queries of a board waiting their turn at most, all clients together.
SERVER_BACKLOG = 4096
#: Clients whose session tags and last-heard times a board keeps at most.
CLIENT_RECORDS = 256
#: Seconds after which a client not heard from is forgotten.
CLIENT_EXPIRY = 600.0
#: Clients with a liveliness token the server tracks at most (their records stay).
LIVE_CLIENTS = 1024

V = TypeVar("V")


def oversized(query: zenoh.Query) -> str | None:
    """Why the query is too large to read (None: it is not); from lengths alone."""
    payload = query.payload
    if payload is not None and len(payload) > MAX_PAYLOAD:
        return (
            f"a query carries one request frame of at most {MAX_PAYLOAD} bytes, not {len(payload)}"
        )
    attachment = query.attachment
    if attachment is not None and len(attachment) > MAX_ATTACHMENT:
        return (
            f"a query's attachment (the client's ID) has at most {MAX_ATTACHMENT} bytes, "
            f"not {len(attachment)}"
        )
    return None


def fair_key(query: zenoh.Query, live: Set[str]) -> bytes:
    """The client a query counts against: its attachment if that client's liveliness
    token is up (``live``), else ``b""``: every query without a live client -- no
    attachment, or one made up -- shares one client's share."""
    attachment = query.attachment
    if attachment is None:
        return b""
    raw = attachment.to_bytes()
    return raw if raw.decode(errors="replace") in live else b""


class ClientQueues:
    """Queries in progress and waiting, per client (see the module docstring).

    Not thread safe by itself: the served board calls it under its own lock, from Zenoh's
    threads (:meth:`admit`) and from the loop (:meth:`done`).
    """

    def __init__(
        self, per_client: int = CLIENT_QUERIES, now: Callable[[], float] = time.monotonic
    ) -> None:
        self.per_client = per_client
        self._now = now
        #: Clients by the time of their last query, oldest first (those within
        #: ACTIVE_WINDOW: at most one per live client, plus the shared one).
        self._active: collections.OrderedDict[bytes, float] = collections.OrderedDict()
        self._running: dict[bytes, int] = {}
        self._waiting: dict[bytes, collections.deque[zenoh.Query]] = {}
        self._key_of: dict[int, bytes] = {}  # id() of each query in progress: its client
        self._backlog = 0

    def admit(self, key: bytes, query: zenoh.Query) -> bool | str:
        """True: ``query`` goes on now; False: it waits its turn (:meth:`done` returns it
        later); a string: it is refused, for this reason."""
        self._touch(key)
        waiting = self._waiting.get(key)
        running = self._running.get(key, 0)
        if waiting is None and running < self.share():
            self._running[key] = running + 1
            self._key_of[id(query)] = key
            return True
        if waiting is None:
            waiting = self._waiting[key] = collections.deque()
        if len(waiting) >= CLIENT_BACKLOG or self._backlog >= SERVER_BACKLOG:
            if not waiting:
                del self._waiting[key]
            return (
                f"too many queries waiting on this server (at most {CLIENT_QUERIES} of one "
                f"client go on at once, {CLIENT_BACKLOG} wait): this one was not sent"
            )
        waiting.append(query)
        self._backlog += 1
        return False

    def done(self, query: zenoh.Query) -> list[zenoh.Query]:
        """An admitted ``query`` was answered: its client's next waiting queries, now
        admitted, up to its share (none: none waits, the client is over its share since
        another became active, or ``query`` was never admitted)."""
        key = self._key_of.pop(id(query), None)
        if key is None:
            return []
        running = self._running.get(key, 0) - 1
        waiting = self._waiting.get(key)
        following = []
        if waiting:
            share = self.share()
            while waiting and running < share:  # the share may have grown: fill it again
                admitted = waiting.popleft()
                self._backlog -= 1
                self._key_of[id(admitted)] = key
                following.append(admitted)
                running += 1
            if not waiting:
                del self._waiting[key]
        if running > 0:
            self._running[key] = running
        else:
            self._running.pop(key, None)
        return following

    def drain(self) -> Iterator[zenoh.Query]:
        """Every waiting query, removed (the board is going away)."""
        for waiting in self._waiting.values():
            yield from waiting
        self._waiting.clear()
        self._running.clear()
        self._key_of.clear()
        self._backlog = 0

    def _touch(self, key: bytes) -> None:
        """``key`` sent a query now: it is active; clients quiet for ACTIVE_WINDOW are not."""
        now = self._now()
        active = self._active
        active[key] = now
        active.move_to_end(key)
        while active and next(iter(active.values())) < now - ACTIVE_WINDOW:
            active.popitem(last=False)

    def share(self) -> int:
        """Queries one client may have on the board now: an equal part of
        ``per_client`` among the active clients: those with a query on the board, and
        those whose last query came in the last ACTIVE_WINDOW seconds."""
        active = self._active
        count = len(active) + sum(1 for key in self._running if key not in active)
        return max(MIN_SHARE, self.per_client // max(1, count))

    @property
    def clients(self) -> int:
        """Clients with a query in progress or waiting."""
        return len(self._running.keys() | self._waiting.keys())


class ClientRecords(Generic[V]):
    """Per-client values: at most ``limit`` clients, each forgotten ``expiry`` seconds
    after it was last stored or read, least recently used first; ``keep`` names the
    clients never forgotten (the failsafe's owner, the streamer)."""

    def __init__(
        self,
        now: Callable[[], float],
        keep: Callable[[str], bool],
        *,
        limit: int = CLIENT_RECORDS,
        expiry: float = CLIENT_EXPIRY,
    ) -> None:
        self._now = now
        self._keep = keep
        self.limit = limit
        self.expiry = expiry
        self._items: collections.OrderedDict[str, tuple[float, V]] = collections.OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._items)

    def __contains__(self, client: object) -> bool:
        return client in self._items

    def get(self, client: str) -> V | None:
        with self._lock:
            item = self._items.get(client)
            if item is None:
                return None
            self._items[client] = (self._now(), item[1])
            self._items.move_to_end(client)
            return item[1]

    def peek(self, client: str, default: V) -> V:
        """The value without counting as a use."""
        item = self._items.get(client)
        return default if item is None else item[1]

    def __setitem__(self, client: str, value: V) -> None:
        with self._lock:
            now = self._now()
            self._items[client] = (now, value)
            self._items.move_to_end(client)
            self._forget(now)

    def pop(self, client: str) -> None:
        with self._lock:
            self._items.pop(client, None)

    def _forget(self, now: float) -> None:
        """Drop expired clients and, past the limit, the least recently used ones."""
        kept: list[tuple[str, tuple[float, V]]] = []
        while self._items:
            client, item = next(iter(self._items.items()))
            if len(self._items) + len(kept) <= self.limit and now - item[0] <= self.expiry:
                break
            del self._items[client]
            if self._keep(client):
                kept.append((client, item))
        for client, item in kept:  # back at the front: the oldest of the rest
            self._items[client] = item
            self._items.move_to_end(client, last=False)
