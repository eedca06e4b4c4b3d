"""Requests put on the link from other threads (``Transport.request_from_thread``).

A server answers network queries on its network library's threads; the transport lets
it send from there.  The oracle is the far end of a pseudo-terminal: it numbers the
frames in the order they reached it and answers each with its number, so every caller
can check that its reply is the one for its own request, whichever thread sent it.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import random
import sys
import threading
from collections.abc import Iterator

import anyio
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardDisconnectedError, BoardTimeoutError
from arduinoio_async.protocol.session import Exchange
from arduinoio_async.transport import Transport, open_serial_stream
from arduinoio_async.transport._serial import SerialByteStream

pytestmark = pytest.mark.anyio


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"  # requests from threads need the loop's push mode


@pytest.fixture
def pty() -> Iterator[tuple[int, str]]:
    master, slave = os.openpty()
    try:
        yield master, os.ttyname(slave)
    finally:
        os.close(slave)
        with contextlib.suppress(OSError):  # a test closed it
            os.close(master)


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
    # Threads take turns with the loop every 10 us instead of every 5 ms: the threads'
    # sends land between any two steps of the loop's, collected writes included.
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    try:
        await _share_one_order(pty)
    finally:
        sys.setswitchinterval(previous)


async def _share_one_order(pty: tuple[int, str]) -> None:
    master, path = pty
    tasks, threads, per_caller, burst = 6, 3, 40, 4
    total = (tasks + threads) * per_caller
    received: list[p.AnalogRead] = []
    board = threading.Thread(target=_numbering_board, args=(master, total, received))
    board.start()
    outcomes: list[tuple[p.AnalogRead, p.AnalogReadReply]] = []
    refused = 0
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=5.0) as link:
        loop = asyncio.get_running_loop()

        def track(request: p.AnalogRead, exchange: Exchange, settled: threading.Event) -> None:
            def record(_: object) -> None:
                assert exchange.error is None, exchange.error
                assert isinstance(exchange.reply, p.AnalogReadReply)
                outcomes.append((request, exchange.reply))
                settled.set()

            link.adopt(exchange).add_done_callback(record)

        def sender(seed: int) -> None:
            """Bursts of requests from this thread, each burst sent without waiting."""
            nonlocal refused
            rng = random.Random(seed)
            for _ in range(per_caller // burst):
                settled = [threading.Event() for _ in range(burst)]
                for done in settled:
                    request = p.AnalogRead(rng.randrange(6))
                    exchange = link.request_from_thread(request)
                    if exchange is None:  # the loop held the link: it goes through the loop
                        refused += 1
                        reply = anyio.from_thread.run(link.request, request)
                        outcomes.append((request, reply))
                        done.set()
                    else:
                        loop.call_soon_threadsafe(track, request, exchange, done)
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
    async with Transport(stream, timeout=1.0) as link:
        with stream.lock:  # the loop is busy with the link: the thread never waits
            assert await anyio.to_thread.run_sync(link.request_from_thread, p.ReadId()) is None
    assert await anyio.to_thread.run_sync(link.request_from_thread, p.ReadId()) is None


async def test_an_unanswered_request_from_a_thread_times_out(pty: tuple[int, str]) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=1.0) as link:
        exchange = await anyio.to_thread.run_sync(
            lambda: link.request_from_thread(p.ReadId(), timeout=0.05)
        )
        assert exchange is not None
        sent = await anyio.to_thread.run_sync(os.read, master, 16)
        assert sent == p.ReadId().encode()  # on the wire at once
        with anyio.fail_after(2):
            await link.adopt(exchange)
        assert isinstance(exchange.error, BoardTimeoutError)


async def test_a_request_from_a_thread_on_a_lost_port_fails(pty: tuple[int, str]) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=5.0) as link:
        os.close(master)  # the cable is pulled
        # Called before the loop can notice (no await in between): the write fails in
        # "the thread", and the loop, told so, loses the port and fails the request.
        exchange = link.request_from_thread(p.ReadId())
        assert exchange is not None and not exchange.done
        with anyio.fail_after(2):
            await link.adopt(exchange)
        assert isinstance(exchange.error, BoardDisconnectedError)
        with pytest.raises(BoardDisconnectedError):
            await link.request(p.ReadId())
