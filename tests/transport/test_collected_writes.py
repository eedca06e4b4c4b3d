"""Pipelined requests woken by one wave of replies go out in one write, in call order.

The oracle counts the stream's ``os.write`` calls (the cost being saved) and reads what
reached the far end of a pseudo-terminal (the order).
"""

from __future__ import annotations

import asyncio
import os
import select
import threading

import anyio
import anyio.lowlevel
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardDisconnectedError
from arduinoio_async.transport import Transport, open_serial_stream
from arduinoio_async.transport._serial import SerialByteStream

pytestmark = pytest.mark.anyio

#: The test's own writes (the far end's) are not counted.
_far_write = os.write


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"  # collecting needs the loop's callbacks (push mode)


@pytest.fixture
def writes(monkeypatch: pytest.MonkeyPatch) -> list[bytes]:
    """Every ``os.write`` the serial stream makes, in order."""
    made: list[bytes] = []

    def counting_write(fd: int, data: bytes) -> int:
        made.append(bytes(data))
        return _far_write(fd, data)

    monkeypatch.setattr(os, "write", counting_write)  # the stream calls os.write
    return made


def _readable(fd: int) -> bool:
    return bool(select.select([fd], [], [], 0)[0])


async def test_collected_sends_go_out_together_after_the_queued_callbacks(
    pty: tuple[int, str], writes: list[bytes]
) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    assert isinstance(stream, SerialByteStream) and stream.send_nowait is not None
    try:
        stream.collect_sends()
        stream.send_nowait(b"\x01")
        stream.send_nowait(b"\x02\x03")
        assert writes == [] and not _readable(master)  # held until the callback runs
        await anyio.lowlevel.checkpoint()
        assert writes == [b"\x01\x02\x03"]
        assert os.read(master, 16) == b"\x01\x02\x03"
        stream.send_nowait(b"\x04")  # no collection asked for: written at once
        assert writes[-1] == b"\x04"
        assert os.read(master, 16) == b"\x04"
    finally:
        await stream.aclose()


async def test_a_port_lost_under_a_collected_write_is_reported_not_raised(
    pty: tuple[int, str],
) -> None:
    master, path = pty
    stream = await open_serial_stream(path)
    assert isinstance(stream, SerialByteStream) and stream.send_nowait is not None
    lost = anyio.Event()
    loop_errors: list[object] = []
    asyncio.get_running_loop().set_exception_handler(lambda _, ctx: loop_errors.append(ctx))
    try:
        stream.attach(lambda data: None, lambda exc: lost.set())
        stream.collect_sends()
        stream.send_nowait(b"\x01")
        os.close(master)  # the cable is pulled before the callback writes
        with anyio.fail_after(2):
            await lost.wait()
        with pytest.raises(anyio.BrokenResourceError):
            stream.send_nowait(b"\x02")
    finally:
        await stream.aclose()
    assert loop_errors == []


def _responder(master: int, wave: int, total: int, received: list[p.GpioWrite]) -> None:
    """Answers GPIO WRITEs in waves: waits for ``wave`` requests (or the rest), then sends
    all their replies in one write, so the host wakes several callers at once."""
    decoder = p.Decoder.from_host()
    pending: list[bytes] = []
    while len(received) < total:
        for frame in decoder.feed(os.read(master, 4096)):
            assert isinstance(frame, p.GpioWrite)
            received.append(frame)
            pending.append(p.GpioWriteReply(frame.pin, frame.value).encode())
        if len(pending) >= min(wave, total - len(received) + len(pending)):
            _far_write(master, b"".join(pending))
            pending.clear()


async def test_pipelined_callers_share_writes_and_keep_call_order(
    pty: tuple[int, str], writes: list[bytes]
) -> None:
    master, path = pty
    tasks, per_task = 8, 40
    total = tasks * per_task
    received: list[p.GpioWrite] = []
    called: list[p.GpioWrite] = []
    responder = threading.Thread(
        target=_responder, args=(master, tasks, total, received), daemon=True
    )
    responder.start()
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=5.0) as link:

        async def caller(index: int) -> None:
            for call in range(per_task):
                request = p.GpioWrite(2 + index, bool(call % 2))
                called.append(request)  # call order: request() sends before it suspends
                reply = await link.request(request)
                assert (reply.pin, reply.value) == (request.pin, request.value)

        with anyio.fail_after(20):
            async with anyio.create_task_group() as tg:
                for index in range(tasks):
                    tg.start_soon(caller, index)
    await anyio.to_thread.run_sync(responder.join, 5.0)
    assert [(r.pin, r.value) for r in received] == [(r.pin, r.value) for r in called]
    # every wave of replies wakes up to 8 callers; their requests share one write
    print(f"\n{total} requests in {len(writes)} writes")
    assert len(writes) < total / 2


async def test_a_lone_request_is_written_at_once(pty: tuple[int, str], writes: list[bytes]) -> None:
    """Sequential requests never wait for a collection: each goes out inside request()."""
    master, path = pty
    stream = await open_serial_stream(path)
    async with Transport(stream, timeout=2.0) as link:
        for call in range(20):
            async with anyio.create_task_group() as tg:
                tg.start_soon(link.request, p.ReadId())
                await anyio.lowlevel.checkpoint()  # the request() task ran up to its wait
                assert len(writes) == call + 1  # written by request() itself
                assert os.read(master, 16) == p.ReadId().encode()
                _far_write(master, p.ReadIdReply(0x0102).encode())
    with pytest.raises(BoardDisconnectedError):
        await link.request(p.ReadId())
