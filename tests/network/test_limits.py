"""What one client may cost a served board (see ``network/_limits.py``).

A ``BoardServer`` in this process serves a FakeBoard on a Zenoh session that listens
nowhere; the tests query it on the same session with raw gets, so each query's payload
and attachment are exactly what a hostile or runaway client would send.  Each test failed
on the server before its fix:

* a 4 MB payload was decoded byte by byte (seconds, under the board's lock) and then
  refused as "not one request"; a 1 KB attachment was accepted (and cached);
* every distinct attachment stayed in the server's records for good (tags, last-heard
  times, the attachment cache);
* a client that sent 400 queries at once put all of them ahead of another client's
  request.
"""

from __future__ import annotations

import json
import threading
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import cast

import anyio
import zenoh

from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.network import zenoh_config
from arduinoio_async.network._keys import (
    MAX_MESSAGE,
    client_key,
    decode_fault,
    request_key,
    undeclare,
)
from arduinoio_async.network._limits import (
    ACTIVE_WINDOW,
    CLIENT_QUERIES,
    CLIENT_RECORDS,
    MAX_ATTACHMENT,
    MAX_PAYLOAD,
    MIN_SHARE,
    ClientQueues,
    ClientRecords,
)
from arduinoio_async.network._served_board import KNOWN_FRAMES, ServedBoard
from arduinoio_async.network._server import BoardServer
from arduinoio_async.testing import FakeBoard, Faults

BOARD = 0x0021


class _OneBoard:
    """The part of a BoardManager the server uses: one board, no events."""

    def __init__(self, board: Board) -> None:
        self.board = board

    def present(self) -> dict[int, Board]:
        return {self.board.board_id: self.board}

    def subscribe(self, callback: Callable[..., None]) -> Callable[[], None]:
        return lambda: None


@asynccontextmanager
async def served_fake(
    faults: Faults | None = None,
) -> AsyncIterator[tuple[ServedBoard, zenoh.Session]]:
    async with (
        FakeBoard(board_id=BOARD, faults=faults or Faults()) as fake,
        Board.connect(fake.host_stream) as board,
    ):
        session = await anyio.to_thread.run_sync(zenoh.open, zenoh_config())
        try:
            server = BoardServer(_OneBoard(board), session)  # type: ignore[arg-type]
            async with anyio.create_task_group() as tg:
                await tg.start(server.run)
                yield server.served[BOARD], session
                tg.cancel_scope.cancel()
        finally:
            await anyio.to_thread.run_sync(session.close)


class Replies:
    """Replies to raw gets, in the order they came (from Zenoh's threads)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.order: list[tuple[str, str]] = []  # (who, outcome)
        self.done = threading.Condition(self.lock)

    def get(
        self, session: zenoh.Session, who: str, payload: bytes, attachment: bytes | None
    ) -> None:
        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                outcome = reply.ok.payload.to_bytes().hex()
            else:
                assert reply.err is not None
                fault = decode_fault(reply.err.payload.to_bytes())
                outcome = f"{fault.error}: {fault.message}"
            with self.lock:
                self.order.append((who, outcome))
                self.done.notify_all()

        session.get(
            request_key(BOARD),
            handler=zenoh.handlers.Callback(on_reply),
            payload=payload,
            attachment=attachment,
            timeout=30.0,
        )

    def wait(self, count: int, timeout: float = 20.0) -> list[tuple[str, str]]:
        with self.lock:
            if not self.done.wait_for(lambda: len(self.order) >= count, timeout):
                raise AssertionError(f"{len(self.order)} of {count} replies came")
            return list(self.order)

    async def outcome(self, who: str) -> str:
        def find() -> str:
            with self.lock:
                self.done.wait_for(lambda: any(w == who for w, _ in self.order), 20.0)
                return next(o for w, o in self.order if w == who)

        return await anyio.to_thread.run_sync(find)


async def test_too_large_a_payload_or_attachment_is_refused_from_its_length() -> None:
    async with served_fake() as (served, session):
        replies = Replies()
        replies.get(session, "huge payload", bytes(4 << 20), b"attacker")
        replies.get(session, "long attachment", p.ReadId().encode(), b"x" * 1024)
        replies.get(session, "legit", p.ReadId().encode(), b"legit")
        huge = await replies.outcome("huge payload")
        assert huge.startswith("ProtocolError") and f"at most {MAX_PAYLOAD} bytes" in huge
        long = await replies.outcome("long attachment")
        assert long.startswith("ProtocolError") and f"at most {MAX_ATTACHMENT} bytes" in long
        assert await replies.outcome("legit") == p.ReadIdReply(BOARD).encode().hex()
        assert b"x" * 1024 not in served._clients
        # the longest real frame is well inside the limit
        longest = max(t.LAYOUT.max_size for t in p.REQUEST_TYPES.values())
        assert longest < MAX_PAYLOAD <= 2 * longest


def test_zenoh_drops_a_message_larger_than_any_of_ours() -> None:
    """Between processes a query of megabytes is dropped by Zenoh before it is whole (its
    sender times out), so it costs this process no more than MAX_MESSAGE bytes."""
    config = zenoh_config(listen=["tcp/127.0.0.1:0"])
    assert json.loads(config.get_json("transport/link/rx/max_message_size")) == MAX_MESSAGE
    assert MAX_PAYLOAD < MAX_MESSAGE <= 64 * 1024


async def test_per_client_records_stay_bounded_and_a_live_client_keeps_its_tag() -> None:
    async with served_fake() as (served, session):
        token = session.liveliness().declare_token(client_key("legit"))
        try:
            with anyio.fail_after(5):
                while "legit" not in served.server.live_clients:  # noqa: ASYNC110 (no event)
                    await anyio.sleep(0.01)
            replies = Replies()
            replies.get(session, "legit set", p.SetSession(0x5A).encode(), b"legit")
            assert await replies.outcome("legit set") == p.SetSessionReply(0x5A).encode().hex()
            count = 3 * CLIENT_RECORDS
            for number in range(count):
                attachment = f"made-up-{number}".encode()
                replies.get(session, "flood", p.SetSession(number & 0xFF).encode(), attachment)
                replies.get(session, "flood", p.ReadStatus().encode(), attachment)
            await anyio.to_thread.run_sync(replies.wait, 1 + 2 * count)
            assert len(served.policy.tags) <= CLIENT_RECORDS
            assert len(served.policy.last_heard) <= CLIENT_RECORDS
            assert len(served._clients) <= KNOWN_FRAMES
            # The live client's tag outlived the flood: its status shows its own session.
            replies.get(session, "legit status", p.ReadStatus().encode(), b"legit")
            status = p.Decoder.from_board().feed(
                bytes.fromhex(await replies.outcome("legit status"))
            )
            assert isinstance(status[0], p.ReadStatusReply) and status[0].session == 0x5A
        finally:
            undeclare(token)


def test_records_expire_and_kept_clients_stay() -> None:
    now = [0.0]
    kept = {"owner"}
    records = ClientRecords[int](lambda: now[0], kept.__contains__, limit=3, expiry=10.0)
    records["owner"] = 1
    records["a"] = 2
    now[0] = 5.0
    records["b"] = 3
    assert records.get("a") == 2  # a use: "a" is now the most recent
    records["c"] = 4  # over the limit: the least recently used not kept ("b") goes
    assert "b" not in records and all(k in records for k in ("owner", "a", "c"))
    now[0] = 100.0
    records["d"] = 5  # everything else expired; the owner stays
    assert "owner" in records and "d" in records and "a" not in records and "c" not in records
    assert len(records) == 2


async def test_a_flooding_client_holds_only_its_share_ahead_of_another() -> None:
    # Each reply takes the board 10 ms, so the flood is still waiting when the legit query
    # comes even on a loaded machine: the admitted 272 take 2.7 s to answer, and sending
    # the 400 took up to 0.4 s on CI (at 1 ms a reply, a slow send let the flood drain).
    async with served_fake(Faults(delay=(0.01, 0.01))) as (served, session):
        replies = Replies()
        flood = 400
        token = session.liveliness().declare_token(client_key("legit"))
        with anyio.fail_after(5):
            while "legit" not in served.server.live_clients:  # noqa: ASYNC110 (no event)
                await anyio.sleep(0.01)

        def send_flood() -> None:
            for _ in range(flood):
                replies.get(session, "runaway", p.ReadId().encode(), b"runaway")

        await anyio.to_thread.run_sync(send_flood)
        with replies.lock:
            answered_when_sent = len(replies.order)
        replies.get(session, "legit", p.ReadId().encode(), b"legit")
        order = await anyio.to_thread.run_sync(replies.wait, flood + 1, 60.0)
        read_id = p.ReadIdReply(BOARD).encode().hex()
        legit_at = next(i for i, (who, _) in enumerate(order) if who == "legit")
        assert order[legit_at][1] == read_id
        # The runaway's queries past its backlog were refused (not sent to the board).
        refused = [o for who, o in order if who == "runaway" and o != read_id]
        assert all(o.startswith("UsageError: too many queries waiting") for o in refused)
        answered = [i for i, (who, o) in enumerate(order) if who == "runaway" and o == read_id]
        waiting = sum(1 for i in answered if i >= answered_when_sent)
        ahead = sum(1 for i in answered if answered_when_sent <= i < legit_at)
        print(
            f"\nflood: {waiting} answered after the legit query went ({len(refused)} refused), "
            f"{ahead} of them before it"
        )
        assert waiting > 4 * CLIENT_QUERIES, "the flood was over too soon"
        # The runaway client holds at most its share of places ahead of another client's
        # request (plus the few answered while that request crossed to the board).
        assert ahead <= 2 * CLIENT_QUERIES
        undeclare(token)


async def test_made_up_clients_share_one_share() -> None:
    """Queries whose attachment names no live client (one made up per query) count as one
    client: at most its share of them is ahead of a live client's request."""
    # 10 ms a reply: the 400-query flood outlasts its own sending on a loaded machine
    async with served_fake(Faults(delay=(0.01, 0.01))) as (served, session):
        replies = Replies()
        token = session.liveliness().declare_token(client_key("legit"))
        with anyio.fail_after(5):
            while "legit" not in served.server.live_clients:  # noqa: ASYNC110 (no event)
                await anyio.sleep(0.01)
        flood = 400

        def send_flood() -> None:
            for number in range(flood):
                replies.get(session, "made-up", p.ReadStatus().encode(), b"made-up-%d" % number)

        await anyio.to_thread.run_sync(send_flood)
        with replies.lock:
            answered_when_sent = len(replies.order)
        replies.get(session, "legit", p.ReadId().encode(), b"legit")
        order = await anyio.to_thread.run_sync(replies.wait, flood + 1, 60.0)
        legit_at = next(i for i, (who, _) in enumerate(order) if who == "legit")
        assert order[legit_at][1] == p.ReadIdReply(BOARD).encode().hex()
        board_answers = [
            i for i, (who, o) in enumerate(order) if who == "made-up" and "Error" not in o
        ]
        ahead = sum(1 for i in board_answers if answered_when_sent <= i < legit_at)
        waiting = sum(1 for i in board_answers if i >= answered_when_sent)
        print(
            f"\nmade-up clients: {waiting} answered after the legit query went, {ahead} before it"
        )
        assert waiting > 4 * CLIENT_QUERIES, "the flood was over too soon"
        assert ahead <= 2 * CLIENT_QUERIES
        undeclare(token)


async def test_a_flooding_client_gets_half_the_link_while_another_client_is_active() -> None:
    """Two clients active: the runaway holds only half of the queries a client may have on
    the board at once, so a client calling one request after another (a control loop)
    waits behind at most that half, not behind a whole client's share every time."""
    async with served_fake(Faults(delay=(0.01, 0.01))) as (served, session):
        replies = Replies()
        flood = 400
        token = session.liveliness().declare_token(client_key("legit"))
        with anyio.fail_after(5):
            while "legit" not in served.server.live_clients:  # noqa: ASYNC110 (no event)
                await anyio.sleep(0.01)

        def send_flood() -> None:
            for _ in range(flood):
                replies.get(session, "runaway", p.ReadId().encode(), b"runaway")

        await anyio.to_thread.run_sync(send_flood)
        calls = 4
        sent_at = []
        for call in range(calls):  # one after another, as a control loop calls
            with replies.lock:
                sent_at.append(len(replies.order))
            replies.get(session, f"legit-{call}", p.ReadId().encode(), b"legit")
            assert await replies.outcome(f"legit-{call}") == p.ReadIdReply(BOARD).encode().hex()
        order = await anyio.to_thread.run_sync(replies.wait, flood + calls, 60.0)
        answered = [i for i, (who, o) in enumerate(order) if who == "runaway" and "Error" not in o]
        ahead = []
        for call in range(calls):
            at = next(i for i, (who, _) in enumerate(order) if who == f"legit-{call}")
            ahead.append(sum(1 for i in answered if sent_at[call] <= i < at))
        print(f"\nrunaway replies ahead of each legit call: {ahead}")
        assert sum(1 for i in answered if i >= sent_at[-1]) > CLIENT_QUERIES, "flood over"
        # the first call finds the runaway's whole share on the board; later ones half of it
        # (plus the one or two answered while a request crossed to the board)
        assert max(ahead[1:]) <= CLIENT_QUERIES // 2 + 2, ahead
        undeclare(token)


def test_the_share_shrinks_while_another_client_is_active_and_grows_back() -> None:
    """ClientQueues alone, on a clock of its own: a client over its share gives places
    back as its queries are answered, and fills its whole share again once the other
    client has been quiet for ACTIVE_WINDOW."""
    clock = [0.0]
    queues = ClientQueues(now=lambda: clock[0])
    flood = [cast(zenoh.Query, object()) for _ in range(40)]
    assert [queues.admit(b"runaway", q) for q in flood] == [True] * 16 + [False] * 24
    legit = cast(zenoh.Query, object())
    assert queues.admit(b"legit", legit) is True  # its own share: never behind the backlog
    assert queues.share() == CLIENT_QUERIES // 2
    # 16 on the board, share 8: the first 8 answers admit nothing, then one for one
    following = [queues.done(q) for q in flood[:9]]
    assert following[:8] == [[]] * 8 and following[8] == [flood[16]]
    queues.done(legit)  # the other client is done, but was heard just now
    assert queues.share() == CLIENT_QUERIES // 2
    clock[0] += ACTIVE_WINDOW * 2
    later = cast(zenoh.Query, object())
    assert queues.admit(b"runaway", later) is False  # behind its own queue; ages the other out
    assert queues.share() == CLIENT_QUERIES
    # 8 on the board, one answered: the share grew back to 16 and is filled again
    assert queues.done(flood[9]) == flood[17:26]
    assert MIN_SHARE <= CLIENT_QUERIES // 8
