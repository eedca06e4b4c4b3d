"""Serial ports (device paths and pyserial URLs) as anyio byte streams.

Theory of operation: for ports with a file descriptor (device paths such as
``/dev/ttyACM0``, pseudo-terminals, ``socket://``) pyserial-asyncio's ``SerialTransport``
registers the descriptor with the event loop and hands received bytes to a protocol that
buffers them for :meth:`SerialByteStream.receive`.  Its stock ``write`` defers every write
to the next loop iteration; :class:`_EagerSerialTransport` writes at once when nothing is
queued, which removes one loop iteration from every request's round trip.  URL forms with
no descriptor (``rfc2217://``, ``loop://``) fall back to blocking reads in a worker
thread.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import os
from typing import Any

import anyio
import anyio.abc
import serial
import serial_asyncio

from ..errors import BoardDisconnectedError, PortBusyError

__all__ = ["SerialByteStream", "open_serial_stream"]


class _EagerSerialTransport(serial_asyncio.SerialTransport):  # type: ignore[misc]
    """SerialTransport that writes immediately when its buffer is empty, and reads and
    writes the descriptor with plain ``os.read``/``os.write``: pyserial's own ``read`` and
    ``write`` run a ``select()`` per call even on a non-blocking port, which costs more
    than the rest of a request."""

    def _read_ready(self) -> None:
        try:
            data = os.read(self._serial.fd, self._max_read_size)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._close(exc=serial.SerialException(f"read failed: {exc}"))
            return
        if data:
            self._protocol.data_received(data)
        else:  # a pseudo-terminal whose other end went away, or an unplugged USB device
            self._close(exc=serial.SerialException("device disconnected"))

    def write(self, data: bytes) -> None:
        if self._closing:
            return
        if not self._write_buffer:
            try:
                written = os.write(self._serial.fd, data)
            except (BlockingIOError, InterruptedError):
                written = 0
            except OSError as exc:
                self._fatal_error(
                    serial.SerialException(f"write failed: {exc}"),
                    "Fatal write error on serial transport",
                )
                return
            if written == len(data):
                return
            data = data[written:]
        super().write(data)


class _BufferingProtocol(asyncio.Protocol):
    def __init__(self) -> None:
        self.chunks: collections.deque[bytes] = collections.deque()
        self.waiter: asyncio.Future[None] | None = None
        self.lost: BaseException | None = None
        self.closed = False

    def data_received(self, data: bytes) -> None:
        self.chunks.append(data)
        self._wake()

    def connection_lost(self, exc: Exception | None) -> None:
        self.closed = True
        self.lost = exc
        self._wake()

    def _wake(self) -> None:
        waiter = self.waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)


class SerialByteStream(anyio.abc.ByteStream):
    """A serial port as an anyio ``ByteStream`` (asyncio backend)."""

    def __init__(self, transport: _EagerSerialTransport, protocol: _BufferingProtocol) -> None:
        self._transport = transport
        self._protocol = protocol
        self.port: str = transport.serial.port or ""

    async def receive(self, max_bytes: int = 65536) -> bytes:
        protocol = self._protocol
        while not protocol.chunks:
            if protocol.closed:
                if self._transport.is_closing() and protocol.lost is None:
                    raise anyio.ClosedResourceError
                raise anyio.BrokenResourceError(f"serial port {self.port} lost: {protocol.lost}")
            waiter = asyncio.get_running_loop().create_future()
            protocol.waiter = waiter
            try:
                await waiter
            finally:
                protocol.waiter = None
        data = protocol.chunks.popleft()
        while protocol.chunks and len(data) < max_bytes:
            data += protocol.chunks.popleft()
        if len(data) > max_bytes:
            protocol.chunks.appendleft(data[max_bytes:])
            data = data[:max_bytes]
        return data

    def send_nowait(self, item: bytes) -> None:
        """Write without suspending (eagerly, or queued in the transport)."""
        if self._protocol.closed or self._transport.is_closing():
            raise anyio.BrokenResourceError(f"serial port {self.port} is closed")
        self._transport.write(item)

    async def send(self, item: bytes) -> None:
        self.send_nowait(item)

    async def send_eof(self) -> None:
        raise NotImplementedError("serial ports have no end-of-file")

    async def aclose(self) -> None:
        self._transport.close()
        self._protocol._wake()
        await anyio.lowlevel.checkpoint()


class _ThreadedSerialStream(anyio.abc.ByteStream):
    """Fallback for pyserial URLs without a file descriptor: reads in a worker thread."""

    def __init__(self, port: serial.SerialBase) -> None:
        self._serial = port
        self._serial.timeout = 0.05
        self.port = str(port.port)

    async def receive(self, max_bytes: int = 65536) -> bytes:
        while True:
            try:
                data: bytes = await anyio.to_thread.run_sync(self._read, max_bytes)
            except serial.SerialException as exc:
                raise anyio.BrokenResourceError(str(exc)) from exc
            if data:
                return data

    def _read(self, max_bytes: int) -> bytes:
        waiting = self._serial.in_waiting
        return bytes(self._serial.read(min(max(waiting, 1), max_bytes)))

    async def send(self, item: bytes) -> None:
        try:
            await anyio.to_thread.run_sync(self._serial.write, item)
        except serial.SerialException as exc:
            raise anyio.BrokenResourceError(str(exc)) from exc

    async def send_eof(self) -> None:
        raise NotImplementedError("serial ports have no end-of-file")

    async def aclose(self) -> None:
        await anyio.to_thread.run_sync(self._serial.close)


def _has_fileno(port: serial.SerialBase) -> bool:
    """A POSIX serial port (device or pty) whose descriptor the event loop can watch."""
    return os.name == "posix" and isinstance(getattr(port, "fd", None), int)


async def open_serial_stream(
    url: str, baudrate: int = 115200, **serial_options: Any
) -> anyio.abc.ByteStream:
    """Open ``url`` (a device path or any pyserial URL) as a byte stream.

    The port is opened exclusively (pyserial's ``exclusive=True``: an advisory ``flock`` on
    POSIX), so a second program -- ``arduinoio list`` while a robot runs -- cannot steal the
    first one's replies.  Raises :class:`PortBusyError` when another process holds the port
    and :class:`BoardDisconnectedError` when it cannot be opened for any other reason.
    """
    serial_options.setdefault("exclusive", True)
    try:
        port = serial.serial_for_url(
            url, baudrate=baudrate, timeout=0, write_timeout=0, do_not_open=True, **serial_options
        )
        await anyio.to_thread.run_sync(port.open)
    except (serial.SerialException, OSError, ValueError) as exc:
        if "exclusively lock" in str(exc):  # pyserial's wording for a failed flock
            raise PortBusyError(url) from exc
        raise BoardDisconnectedError(f"cannot open {url}: {exc}") from exc
    if not _has_fileno(port):
        return _ThreadedSerialStream(port)
    loop = asyncio.get_running_loop()
    protocol = _BufferingProtocol()
    transport = _EagerSerialTransport(loop, protocol, port)
    # connection_made and the reader registration are scheduled with call_soon.
    await asyncio.sleep(0)
    with contextlib.suppress(Exception):
        transport.set_write_buffer_limits(high=1 << 20)
    return SerialByteStream(transport, protocol)
