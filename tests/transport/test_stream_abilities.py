"""The transport uses what a stream *declares* (transport/_streams.py), never what it
happens to have: a stream's abilities are looked at once, when the transport is built."""

from __future__ import annotations

import threading
from collections.abc import Callable

import anyio
import anyio.abc
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport import (
    CollectedWrites,
    ImmediateSender,
    LinkAttribute,
    MemoryByteStream,
    PushStream,
    RelayingStream,
    SerialByteStream,
    ThreadSafeSender,
    Transport,
    abilities_of,
)


class Undeclared(anyio.abc.ByteStream):
    """Methods named as the interfaces' are, declared nowhere: each one fails if called."""

    def __init__(self, inner: anyio.abc.ByteStream) -> None:
        self.inner = inner
        self.port = "not a port name the transport may read"
        self.lock = "not a lock"
        self.called: list[str] = []

    def attach(self, on_data: Callable[[bytes], None], on_lost: object) -> bool:
        self.called.append("attach")
        raise AssertionError("attach is not declared")

    def send_nowait(self, item: bytes) -> None:
        self.called.append("send_nowait")
        raise AssertionError("send_nowait is not declared")

    def relay_failures_to(self, relay: object) -> None:
        self.called.append("relay_failures_to")

    async def receive(self, max_bytes: int = 65536) -> bytes:
        return await self.inner.receive(max_bytes)

    async def send(self, item: bytes) -> None:
        await self.inner.send(item)

    async def send_eof(self) -> None:
        await self.inner.send_eof()

    async def aclose(self) -> None:
        await self.inner.aclose()


async def test_a_stream_that_declares_nothing_is_read_and_written_by_tasks() -> None:
    async with FakeBoard(board_id=0x0102) as fake:
        stream = Undeclared(fake.host_stream)
        async with Transport(stream, timeout=2.0) as link:
            assert await link.request(p.ReadId()) == p.ReadIdReply(0x0102)
            assert link.name == "link"  # not the undeclared ``port`` attribute
            assert link.framing is p.Framing.XOR
        assert stream.called == []


def test_the_memory_stream_declares_immediate_writes_only() -> None:
    async def check() -> None:
        async with FakeBoard(board_id=1) as fake:
            stream = fake.host_stream
            assert isinstance(stream, MemoryByteStream)
            abilities = abilities_of(stream)
            assert abilities.send_nowait is not None
            assert abilities.push is None and abilities.collect_sends is None
            assert abilities.thread_sender is None and not abilities.relays
            assert abilities.port == "" and abilities.baudrate is None

    anyio.run(check)


def test_the_serial_stream_declares_every_ability_and_its_line() -> None:
    assert issubclass(SerialByteStream, PushStream)
    assert issubclass(SerialByteStream, ImmediateSender)
    assert issubclass(SerialByteStream, CollectedWrites)
    assert issubclass(SerialByteStream, ThreadSafeSender)
    assert not issubclass(SerialByteStream, RelayingStream)


async def test_a_serial_stream_names_its_port_and_rate(pty: tuple[int, str]) -> None:
    from arduinoio_async.transport import open_serial_stream

    _master, path = pty
    stream = await open_serial_stream(path, 115200)
    try:
        assert stream.extra(LinkAttribute.port) == path
        assert stream.extra(LinkAttribute.baudrate) == 115200
        assert isinstance(stream, SerialByteStream)
        abilities = abilities_of(stream)
        assert abilities.push is stream and abilities.thread_sender is stream
        assert isinstance(stream.lock, type(threading.RLock()))
        link = Transport(stream)
        assert link.name == path
    finally:
        await stream.aclose()


def test_the_network_stream_declares_push_immediate_and_relay() -> None:
    network = pytest.importorskip("arduinoio_async.network._stream")
    cls = network.RemoteByteStream
    assert issubclass(cls, PushStream) and issubclass(cls, ImmediateSender)
    assert issubclass(cls, RelayingStream) and not issubclass(cls, ThreadSafeSender)


def test_an_interface_left_unimplemented_fails_at_construction() -> None:
    class HalfPush(MemoryByteStream, PushStream):
        def attach(self, on_data: object, on_lost: object) -> bool:
            return False

    send, receive = anyio.create_memory_object_stream[bytes](1)
    with pytest.raises(TypeError, match="detach"):
        HalfPush(send, receive)  # type: ignore[abstract]
    send.close()
    receive.close()
