"""The Zenoh-backed byte stream under a normal Transport, against a scripted queryable.

No simulator: a queryable in this process answers request frames the way a test wants
(out of order, with a link fault, not at all), and the transport on the client's end
must still deliver every reply to the caller it was verified for.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from functools import partial

import anyio
import pytest
import zenoh

from arduinoio_async import protocol as p
from arduinoio_async.errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    BoardTimeoutError,
    LinkResyncError,
    UsageError,
)
from arduinoio_async.network import RemoteByteStream, zenoh_config
from arduinoio_async.network._keys import encode_fault, events_key, request_key, undeclare
from arduinoio_async.network._loop import LoopHandle
from arduinoio_async.transport import Transport

BOARD = 0x0009


class ScriptedBoard:
    """A queryable for board 9 whose answers the test releases (``answer``)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.queries: list[zenoh.Query] = []
        self.arrived = anyio.Event()
        self.queryable = session.declare_queryable(
            request_key(BOARD), LoopHandle().forward(self._on_query)
        )

    def _on_query(self, query: zenoh.Query) -> None:
        self.queries.append(query)
        self.arrived.set()
        self.arrived = anyio.Event()

    async def wait_queries(self, count: int) -> None:
        with anyio.fail_after(5):
            while len(self.queries) < count:
                await self.arrived.wait()

    @staticmethod
    def request_of(query: zenoh.Query) -> p.Request[p.Reply]:
        assert query.payload is not None
        (frame,) = p.Decoder.from_host().feed(query.payload.to_bytes())
        assert isinstance(frame, p.Request)
        return frame

    def answer(self, index: int, how: Callable[[zenoh.Query], None] | None = None) -> None:
        query = self.queries[index]
        with query:
            if how is not None:
                how(query)
                return
            request = self.request_of(query)
            if isinstance(request, p.ReadId):
                query.reply(request_key(BOARD), p.ReadIdReply(BOARD).encode())
            elif isinstance(request, p.AnalogRead):
                reply = p.AnalogReadReply(request.channel, 100 * request.channel)
                query.reply(request_key(BOARD), reply.encode())
            elif isinstance(request, p.ReadCapabilities):
                caps = p.ReadCapabilitiesReply(
                    p.PROTOCOL_VERSION, *p.FIRMWARE_VERSION, 0, p.DEFAULT_BAUD, p.RX_FIFO_SIZE
                )
                query.reply(request_key(BOARD), caps.encode())

    def answer_all_from(self, start: int) -> None:
        for index in range(start, len(self.queries)):
            self.answer(index)


@pytest.fixture
async def session() -> AsyncIterator[zenoh.Session]:
    opened = await anyio.to_thread.run_sync(zenoh.open, zenoh_config())
    try:
        yield opened
    finally:
        await anyio.to_thread.run_sync(opened.close)


async def test_replies_are_delivered_in_request_order(session: zenoh.Session) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    results: dict[int, int] = {}
    async with Transport(stream, name="remote") as link:

        async def read(channel: int) -> None:
            results[channel] = (await link.request(p.AnalogRead(channel))).value

        async with anyio.create_task_group() as tg:
            for channel in range(6):
                tg.start_soon(read, channel)
            await board.wait_queries(6)
            for index in reversed(range(6)):  # the network delivers them backwards
                board.answer(index)
    assert results == {channel: 100 * channel for channel in range(6)}


async def test_events_reach_subscribers_between_replies(session: zenoh.Session) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    seen: list[p.Event | p.Reply] = []
    got = anyio.Event()

    def on_event(event: p.Event) -> None:
        seen.append(event)
        got.set()

    async with Transport(stream, name="remote") as link:
        link.subscribe(on_event)
        session.put(events_key(BOARD), p.FailsafeTripped().encode())
        with anyio.fail_after(5):
            await got.wait()
        async with anyio.create_task_group() as tg:
            tg.start_soon(board.wait_queries, 1)

            async def answer() -> None:
                await board.wait_queries(1)
                board.answer(0)

            tg.start_soon(answer)
            seen.append(await link.request(p.ReadId()))
    assert seen == [p.FailsafeTripped(), p.ReadIdReply(BOARD)]


async def test_an_error_reply_frame_is_the_boards_refusal(session: zenoh.Session) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    descriptor = p.AnalogRead.LAYOUT.descriptor
    refusal = p.ErrorReply(p.ClassTag.ANALOG, descriptor, p.ErrorCode.PIN_NOT_CAPABLE)

    async def refuse() -> None:
        await board.wait_queries(1)
        board.answer(0, lambda q: q.reply(request_key(BOARD), refusal.encode()))

    async with Transport(stream, name="remote") as link, anyio.create_task_group() as tg:
        tg.start_soon(refuse)
        with pytest.raises(BoardError) as refused:
            await link.request(p.AnalogRead(3))
        assert refused.value.code is p.ErrorCode.PIN_NOT_CAPABLE
        assert link.state.value == "ready"  # a refusal is no link fault


async def test_a_server_link_fault_never_gives_a_wrong_answer(session: zenoh.Session) -> None:
    """The server's link timed out on the first of three reads: the client's transport sees
    one byte no frame explains in that reply's place.  Whatever it then does to regain
    sync (probe, retry the idempotent read), every caller ends with its own reply or a
    LinkResyncError, and the fault is kept for diagnostics."""
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    outcomes: dict[int, p.AnalogReadReply | LinkResyncError] = {}
    fault = encode_fault(BoardTimeoutError("the server's link timed out"))
    async with Transport(stream, name="remote") as link:

        async def read(channel: int) -> None:
            try:
                outcomes[channel] = await link.request(p.AnalogRead(channel))
            except LinkResyncError as exc:
                outcomes[channel] = exc

        async def board_answers_the_rest() -> None:
            await board.wait_queries(3)
            board.answer(0, lambda q: q.reply_err(fault))
            answered = 1
            while True:  # the remaining reads, and whatever the resync sends
                await board.wait_queries(answered + 1)
                board.answer(answered)
                answered += 1

        async with anyio.create_task_group() as tg:
            tg.start_soon(board_answers_the_rest)
            async with anyio.create_task_group() as reads:
                for channel in range(3):
                    reads.start_soon(read, channel)
            tg.cancel_scope.cancel()
        assert sorted(outcomes) == [0, 1, 2]
        for channel, outcome in outcomes.items():
            if not isinstance(outcome, LinkResyncError):
                assert outcome == p.AnalogReadReply(channel, 100 * channel)
        assert [f.error for f in stream.faults] == ["BoardTimeoutError"]


def fail_query(fault: bytes, query: zenoh.Query) -> None:
    query.reply_err(fault)


@pytest.mark.parametrize("answer_order", [(0, 1, 2, 3), (3, 2, 1, 0)])
async def test_a_server_side_failure_reaches_only_its_own_request(
    session: zenoh.Session, answer_order: tuple[int, ...]
) -> None:
    """With the transport relaying failures (as RemoteBoards wires it), each query's
    outcome on the server reaches that request alone: a timeout there is a
    BoardTimeoutError here, a refusal keeps its class, a failure of unknown fate is a
    LinkResyncError; the other reads get their replies and the link never resyncs."""
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    failures = {
        0: BoardTimeoutError("no reply to AnalogRead in time"),
        1: LinkResyncError("lost sync"),
        3: UsageError("refused"),
    }
    outcomes: dict[int, object] = {}
    async with Transport(stream, name="remote") as link:
        stream.relay_failures_to(link.relay_failure)

        async def read(channel: int) -> None:
            try:
                outcomes[channel] = await link.request(p.AnalogRead(channel))
            except ArduinoIOError as exc:
                outcomes[channel] = exc

        async def answer() -> None:
            await board.wait_queries(4)
            for index in answer_order:
                error = failures.get(index)
                if error is None:
                    board.answer(index)
                else:
                    board.answer(index, partial(fail_query, encode_fault(error)))

        async with anyio.create_task_group() as tg:
            tg.start_soon(answer)
            for channel in range(4):
                tg.start_soon(read, channel)
                await anyio.wait_all_tasks_blocked()  # wire order = channel order
        assert type(outcomes[0]) is BoardTimeoutError
        assert type(outcomes[1]) is LinkResyncError
        assert outcomes[2] == p.AnalogReadReply(2, 200)
        assert type(outcomes[3]) is UsageError and "refused" in str(outcomes[3])
        assert link.state.value == "ready" and len(board.queries) == 4  # no resync probe

        async def answer_next() -> None:
            await board.wait_queries(5)
            board.answer(4)

        async with anyio.create_task_group() as tg:  # and the link goes on
            tg.start_soon(answer_next)
            assert await link.request(p.AnalogRead(5)) == p.AnalogReadReply(5, 500)


async def test_an_unknown_server_failure_is_of_unknown_fate(session: zenoh.Session) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    async with Transport(stream, name="remote") as link, anyio.create_task_group() as tg:
        stream.relay_failures_to(link.relay_failure)

        async def fail_it() -> None:
            await board.wait_queries(1)
            board.answer(0, lambda q: q.reply_err(b'{"error": "SomeNewError", "message": "x"}'))

        tg.start_soon(fail_it)
        with pytest.raises(LinkResyncError, match="SomeNewError on the server"):
            await link.request(p.AnalogRead(1))


def _unplugged(board: ScriptedBoard) -> None:
    undeclare(board.queryable)  # as a server does when its board is unplugged: no answer


def _answered_gone(board: ScriptedBoard) -> None:
    fault = encode_fault(BoardDisconnectedError("board 0x0009 is not connected"))
    board.answer(0, lambda query: query.reply_err(fault))


@pytest.mark.parametrize("vanish", [_unplugged, _answered_gone])
async def test_a_vanished_board_disconnects(
    session: zenoh.Session, vanish: Callable[[ScriptedBoard], None]
) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    async with Transport(stream, name="remote", timeout=30) as link:
        async with anyio.create_task_group() as tg:

            async def vanish_in_flight() -> None:
                await board.wait_queries(1)
                vanish(board)

            tg.start_soon(vanish_in_flight)
            with anyio.fail_after(5), pytest.raises(BoardDisconnectedError):
                await link.request(p.ReadId())
        with pytest.raises(BoardDisconnectedError):
            await link.request(p.ReadId())
    assert len(board.queries) == 1


async def test_a_board_nobody_serves_disconnects_at_once(session: zenoh.Session) -> None:
    stream = RemoteByteStream(session, BOARD, "tester")
    async with Transport(stream, name="remote", timeout=30) as link:
        with anyio.fail_after(5), pytest.raises(BoardDisconnectedError):
            await link.request(p.ReadId())


async def test_a_cancelled_callers_reply_is_consumed_in_order(session: zenoh.Session) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    async with Transport(stream, name="remote") as link:
        with anyio.move_on_after(0.05) as scope:  # gives up before its reply comes
            await link.request(p.AnalogRead(1))
        assert scope.cancelled_caught
        results: list[p.AnalogReadReply] = []

        async def read() -> None:
            results.append(await link.request(p.AnalogRead(2)))

        async with anyio.create_task_group() as tg:
            tg.start_soon(read)
            await board.wait_queries(2)
            board.answer(1)  # the later reply first: it must wait for the abandoned one
            board.answer(0)
        assert results == [p.AnalogReadReply(2, 200)]
        assert link.stats.dropped_late_replies == 1


async def test_a_frame_written_in_pieces_is_one_query_of_the_whole_frame(
    session: zenoh.Session,
) -> None:
    board = ScriptedBoard(session)
    stream = RemoteByteStream(session, BOARD, "tester")
    frame = p.AnalogRead(3).encode()
    try:
        stream.send_nowait(frame)  # whole: remembered
        stream.send_nowait(frame[:1])
        stream.send_nowait(frame[1:])  # the tail alone is not the frame
        stream.send_nowait(frame)
        await board.wait_queries(3)
        assert [q.payload.to_bytes() for q in board.queries if q.payload] == [frame] * 3
    finally:
        await stream.aclose()
