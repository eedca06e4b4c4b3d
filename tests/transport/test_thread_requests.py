"""Requests put on the link from other threads (``Transport.request_from_thread``).

A server answers network queries on its network library's threads; the transport lets
it send from there.  The oracle is the far end of a pseudo-terminal: it numbers the
frames in the order they reached it and answers each with its number, so every caller
can check that its reply is the one for its own request, whichever thread sent it.
"""

from __future__ import annotations

import asyncio
import os
import random
import sys
import threading
from collections.abc import Callable
from typing import Any

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardDisconnectedError, BoardTimeoutError
from arduinoio_async.protocol.session import Exchange
from arduinoio_async.transport import TraceRecord, Transport, open_serial_stream
from arduinoio_async.transport._serial import SerialByteStream

pytestmark = pytest.mark.anyio


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"  # requests from threads need the loop's push mode


def _numbering_board(master: int, total: int, received: list[p.AnalogRead]) -> None:
    """Answers each ANALOG READ with its position in arrival order (as the value), all
    that arrived together in one write."""
    decoder = p.Decoder.from_host()
    while len(received) < total:
        replies = []
        for frame in decoder.feed(os.read(master, 4096)):
            assert isinstance(frame, p.AnalogRead)
            replies.append(p.AnalogReadReply(frame.channel, len(received)).encode())
            received.append(frame)
        os.write(master, b"".join(replies))


async def test_requests_from_threads_and_the_loop_keep_one_order(pty: tuple[int, str]) -> None:
    # Threads take turns with the loop every microsecond or so instead of every 5 ms: their
    # sends land between any two steps of the loop's, collected writes included.
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        await _share_one_order(pty)
    finally:
        sys.setswitchinterval(previous)


async def _share_one_order(pty: tuple[int, str]) -> None:
    master, path = pty
    tasks, threads, per_caller, burst = 6, 4, 96, 8
    total = (tasks + threads) * per_caller
    received: list[p.AnalogRead] = []
    board = threading.Thread(target=_numbering_board, args=(master, total, received))
    board.start()
    outcomes: list[tuple[p.AnalogRead, p.AnalogReadReply]] = []
    refused = 0
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=5.0) as link:

        def recorder(request: p.AnalogRead, settled: threading.Event) -> Callable[[Exchange], None]:
            def record(exchange: Exchange) -> None:
                assert exchange.error is None, exchange.error
                assert isinstance(exchange.reply, p.AnalogReadReply)
                outcomes.append((request, exchange.reply))
                settled.set()

            return record

        def sender(seed: int) -> None:
            """Bursts of requests from this thread, each burst sent without waiting."""
            nonlocal refused
            rng = random.Random(seed)
            for _ in range(per_caller // burst):
                settled = [threading.Event() for _ in range(burst)]
                for done in settled:
                    request = p.AnalogRead(rng.randrange(6))
                    if not link.request_from_thread(request, recorder(request, done)):
                        refused += 1  # the loop held the link: it goes through the loop
                        reply = anyio.from_thread.run(link.request, request)
                        outcomes.append((request, reply))
                        done.set()
                for done in settled:
                    assert done.wait(10)

        async def caller(seed: int) -> None:
            rng = random.Random(seed)
            for _ in range(per_caller):
                request = p.AnalogRead(rng.randrange(6))
                outcomes.append((request, await link.request(request)))

        with anyio.fail_after(30):
            async with anyio.create_task_group() as tg:
                for index in range(threads):
                    tg.start_soon(anyio.to_thread.run_sync, sender, index)
                for index in range(tasks):
                    tg.start_soon(caller, 100 + index)
    await anyio.to_thread.run_sync(board.join, 5.0)
    assert len(outcomes) == len(received) == total
    # Each reply is the one for its own request: the frame numbered with its value.
    assert sorted(reply.value for _, reply in outcomes) == list(range(total))
    for request, reply in outcomes:
        assert reply.channel == request.channel == received[reply.value].channel
    assert refused < threads * per_caller / 2  # the threads' path was the one taken


async def test_a_thread_is_refused_while_the_loop_holds_the_link_or_it_is_closed(
    pty: tuple[int, str],
) -> None:
    _, path = pty
    stream = await open_serial_stream(path)
    assert isinstance(stream, SerialByteStream)
    done: list[Exchange] = []
    async with Transport(stream, timeout=1.0) as link:
        with stream.lock:  # the loop is busy with the link: the thread never waits
            taken = await anyio.to_thread.run_sync(
                link.request_from_thread, p.ReadId(), done.append
            )
        assert not taken
    assert not await anyio.to_thread.run_sync(link.request_from_thread, p.ReadId(), done.append)
    assert done == []  # refused requests are never called back


async def _settled(link: Transport, request: p.Request[Any], **kwargs: float) -> Exchange:
    """Send ``request`` from a worker thread; the exchange once the loop has it done."""
    loop = asyncio.get_running_loop()
    outcome: asyncio.Future[Exchange] = loop.create_future()
    taken = await anyio.to_thread.run_sync(
        lambda: link.request_from_thread(request, outcome.set_result, **kwargs)
    )
    assert taken
    with anyio.fail_after(2):
        return await outcome


async def test_an_unanswered_request_from_a_thread_times_out(pty: tuple[int, str]) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=1.0) as link, anyio.create_task_group() as tg:
        tg.start_soon(_expect_timeout, link)
        sent = await anyio.to_thread.run_sync(os.read, master, 16)
        assert sent == p.ReadId().encode()  # on the wire at once, never answered


async def _expect_timeout(link: Transport) -> None:
    exchange = await _settled(link, p.ReadId(), timeout=0.05)
    assert isinstance(exchange.error, BoardTimeoutError)


async def test_a_reply_to_a_request_from_a_thread_reaches_its_callback(
    pty: tuple[int, str],
) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=1.0) as link:

        async def answer() -> None:
            assert await anyio.to_thread.run_sync(os.read, master, 16) == p.ReadId().encode()
            os.write(master, p.ReadIdReply(0x0107).encode())

        async with anyio.create_task_group() as tg:
            tg.start_soon(answer)
            exchange = await _settled(link, p.ReadId())
        assert exchange.error is None and exchange.reply == p.ReadIdReply(0x0107)


async def test_a_request_from_a_thread_on_a_lost_port_fails(pty: tuple[int, str]) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=5.0) as link:
        os.close(master)  # the cable is pulled
        # Called before the loop can notice (no await in between): the write fails in
        # "the thread", and the loop, told so, loses the port and fails the request.
        loop = asyncio.get_running_loop()
        outcome: asyncio.Future[Exchange] = loop.create_future()
        assert link.request_from_thread(p.ReadId(), outcome.set_result)
        with anyio.fail_after(2):
            exchange = await outcome
        assert isinstance(exchange.error, BoardDisconnectedError)
        with pytest.raises(BoardDisconnectedError):
            await link.request(p.ReadId())


async def test_a_threads_bytes_follow_bytes_the_loop_collected_before(
    pty: tuple[int, str],
) -> None:
    """A wave of replies opened a collection: the loop's sends wait for its one write,
    and a thread's send meanwhile must go after them, not ahead."""
    master, path = pty
    stream = await open_serial_stream(path)
    assert isinstance(stream, SerialByteStream) and stream.send_nowait is not None
    try:
        stream.collect_sends()
        stream.send_nowait(b"\x01")  # the loop's, collected
        with stream.lock:
            assert stream.send_from_thread(b"\x02")  # a thread's, while the wave is open
        await anyio.lowlevel.checkpoint()  # the collected write
        written = await anyio.to_thread.run_sync(os.read, master, 16)
        assert written == b"\x01\x02"
    finally:
        await stream.aclose()
    with stream.lock:
        assert not stream.send_from_thread(b"\x03")  # closed: refused, nothing written


async def test_a_traced_link_takes_requests_only_in_the_loop(pty: tuple[int, str]) -> None:
    """A user's trace hook must never run on another thread."""
    _, path = pty
    stream = await open_serial_stream(path)
    records: list[TraceRecord] = []
    async with Transport(stream, timeout=1.0, trace=records.append) as link:
        assert not await anyio.to_thread.run_sync(link.request_from_thread, p.ReadId(), print)
    assert records == []


async def test_no_thread_slips_between_the_loops_send_and_its_write(
    pty: tuple[int, str],
) -> None:
    """The loop's request is the session's before its bytes are written: a thread that
    comes in between must be refused, or its frame would reach the wire first and take
    the loop's reply."""
    master, path = pty
    stream = await open_serial_stream(path)
    assert isinstance(stream, SerialByteStream) and stream.send_nowait is not None
    write = stream.send_nowait
    taken: list[bool] = []

    def write_after_a_thread_tried(data: bytes) -> None:
        if not taken:  # the first write: a thread tries to send right now
            thread = threading.Thread(
                target=lambda: taken.append(link.request_from_thread(p.AnalogRead(5), print))
            )
            thread.start()
            thread.join()
        write(data)

    # What the transport writes with: it reads the method once, when it is built.
    stream.send_nowait = write_after_a_thread_tried  # type: ignore[method-assign,assignment]
    async with Transport(stream, timeout=1.0) as link, anyio.create_task_group() as tg:

        async def answer() -> None:
            frame = await anyio.to_thread.run_sync(os.read, master, 16)
            assert frame == p.AnalogRead(1).encode()  # the loop's, alone
            os.write(master, p.AnalogReadReply(1, 100).encode())

        tg.start_soon(answer)
        assert await link.request(p.AnalogRead(1)) == p.AnalogReadReply(1, 100)
    assert taken == [False]
