"""Serial ports (device paths and pyserial URLs) as anyio byte streams.

Theory of operation: pyserial opens the port (exclusively) and configures it; after that
the descriptor of a port that has one (device paths such as ``/dev/ttyACM0``,
pseudo-terminals, ``socket://``) is read and written with plain non-blocking
``os.read``/``os.write`` -- pyserial's own ``read``/``write`` run a ``select()`` per call,
which costs more than the rest of a request.  Waiting uses anyio's portable
``wait_readable``/``wait_writable``, so the same stream runs on asyncio, uvloop and trio;
on asyncio it can also push received bytes from the loop's fd-readable callback (see
:class:`SerialByteStream`).  URL forms with no descriptor (``rfc2217://``, ``loop://``)
fall back to blocking reads in a worker thread.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import threading
from collections.abc import Callable, Mapping
from typing import Any

import anyio
import anyio.abc
import anyio.lowlevel
import serial

from ..errors import BoardDisconnectedError, PortBusyError
from ..protocol import DEFAULT_BAUD
from ._latency import port_boot_quiet, tune_link
from ._streams import (
    CollectedWrites,
    ImmediateSender,
    LinkAttribute,
    PushStream,
    ThreadSafeSender,
)

try:  # pyserial's POSIX back end lets termios.error (not an OSError) out of open()
    from termios import error as _TermiosError
except ImportError:  # pragma: no cover - Windows

    class _TermiosError(Exception):  # type: ignore[no-redef]
        """Never raised: stands in for termios.error where there is no termios."""


#: What pyserial raises when a port cannot be opened or configured: a pty or USB device
#: that vanishes between ``open()`` and its ``tcsetattr()`` gives ``termios.error`` (EIO).
_OPEN_ERRORS = (serial.SerialException, OSError, ValueError, _TermiosError)

__all__ = ["SerialByteStream", "open_serial_stream"]


def _line_attributes(
    stream: SerialByteStream | _ThreadedSerialStream,
) -> dict[Any, Callable[[], Any]]:
    """The port's name and baud rate, as :class:`LinkAttribute` says."""
    return {
        LinkAttribute.port: lambda: stream.port,
        LinkAttribute.baudrate: lambda: stream.baudrate,
    }


class SerialByteStream(
    anyio.abc.ByteStream, PushStream, ImmediateSender, CollectedWrites, ThreadSafeSender
):
    """A serial port with a file descriptor as an anyio ``ByteStream``, on any backend.

    ``receive``/``send`` wait with anyio's portable ``wait_readable``/``wait_writable``
    (asyncio, uvloop, trio).  On asyncio the stream can also *push*: :meth:`attach` has
    the loop call ``on_data`` from its fd-readable callback, and ``send_nowait`` writes at
    once (queueing the rest behind a writability callback), so a round trip needs no task
    switch.  A lost port surfaces as ``anyio.BrokenResourceError`` (pull) or ``on_lost``
    (push), never as a traceback from the event loop.

    *One write per wave of replies.*  Received bytes wake the callers whose replies they
    carry; those tasks run in the loop's next iteration, and with many requests pipelined
    each sends its next request at once: one ``os.write`` each, the most expensive step of
    a pipelined request (a pty write wakes its reader: ~10-20 us).  So the transport, when
    one chunk of received bytes has woken several callers, asks the stream to
    :meth:`collect_sends`: what is sent until a callback queued behind those wake-ups
    runs is written by that callback at once, in the order it was sent -- in the same
    loop iteration as the sends, so no request waits for another iteration.  Sends at
    any other time (a lone request and its reply) are written at once.

    *Writes from another thread.*  A server whose requests arrive on a network library's
    threads saves a hop into the loop per request by writing them there
    (:meth:`send_from_thread`, used by ``Transport.request_from_thread``).  :attr:`lock`
    orders those writes with the loop's: whoever holds it may change what goes on the
    wire, so the loop's callbacks here hold it, and the transport holds it from handing
    a request to its session until the request's bytes are written or queued.
    """

    def __init__(self, port: serial.SerialBase) -> None:
        self._serial = port
        self._fd: int = port.fd
        self.port: str = str(port.port or "")
        #: The rate the port was opened at (named in the error when no board answers).
        self.baudrate: int = int(port.baudrate)
        self._closed = False
        self._lost: BaseException | None = None
        self._pending = bytearray()
        #: While not None: bytes sent since received bytes were delivered, written
        #: together by ``_write_collected`` (see the class docstring).
        self._collected: bytearray | None = None
        self._on_data: Callable[[bytes], None] | None = None
        self._on_lost: Callable[[BaseException | None], None] | None = None
        #: Held while the wire's order is decided (see the class docstring); reentrant,
        #: as the loop's read callback holds it while the transport's handler runs.
        self.lock = threading.RLock()
        try:
            self._loop: asyncio.AbstractEventLoop | None = asyncio.get_running_loop()
        except RuntimeError:
            self._loop = None

    @property
    def extra_attributes(self) -> Mapping[Any, Callable[[], Any]]:
        """The port's name and baud rate (:class:`LinkAttribute`)."""
        return _line_attributes(self)

    def can_send_nowait(self) -> bool:
        """Writing without suspending needs asyncio's writability callbacks."""
        return self._loop is not None

    def send_nowait(self, item: bytes) -> None:
        """Write ``item`` at once, or queue it behind a writability callback (asyncio)."""
        if self._loop is None:
            raise RuntimeError("send_nowait needs an asyncio event loop (use send)")
        self._send_nowait(item)

    # ---- push mode (asyncio) -------------------------------------------------------------

    def attach(
        self, on_data: Callable[[bytes], None], on_lost: Callable[[BaseException | None], None]
    ) -> bool:
        """Deliver received bytes to ``on_data`` from the loop's callback; False if this
        backend cannot (then use :meth:`receive`)."""
        if self._loop is None or self._closed:
            return False
        with self.lock:
            self._on_data = on_data
            self._on_lost = on_lost
        self._loop.add_reader(self._fd, self._read_ready)
        return True

    def detach(self) -> None:
        """Stop pushing (the port stays open)."""
        with self.lock:
            if self._on_data is not None and self._loop is not None and not self._closed:
                self._loop.remove_reader(self._fd)
            self._on_data = None

    def _read_ready(self) -> None:
        with self.lock:
            try:
                data = os.read(self._fd, 65536)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                self._port_lost(exc)
                return
            if not data:  # a pseudo-terminal whose other end went away, or an unplugged device
                self._port_lost(None)
                return
            on_data = self._on_data
            if on_data is not None:
                on_data(data)

    def collect_sends(self) -> None:
        """Collect what is sent from now on until the callbacks the loop has queued so far
        have run, then write it in one ``os.write`` (see the class docstring)."""
        with self.lock:
            if self._collected is None and self._loop is not None and not self._closed:
                self._collected = bytearray()
                self._loop.call_soon(self._write_collected)

    def _write_collected(self) -> None:
        with self.lock:
            collected, self._collected = self._collected, None
            if not collected or self._closed or self._lost is not None:
                return
            # A failed write already told the transport (on_lost): every request fails.
            with contextlib.suppress(anyio.BrokenResourceError):
                self._send_nowait(bytes(collected))

    def _port_lost(self, exc: BaseException | None) -> None:
        self._lost = exc or anyio.EndOfStream()
        if self._loop is not None and not self._closed:
            self._loop.remove_reader(self._fd)
            self._loop.remove_writer(self._fd)
        self._on_data = None
        on_lost, self._on_lost = self._on_lost, None
        if on_lost is not None:
            on_lost(exc)

    def _send_nowait(self, item: bytes) -> None:
        # In the loop; where another thread may send, the caller holds ``lock`` (the
        # transport does, from the session's send until here).
        if not self._send_in_turn(item, from_thread=False):
            self._check_open()  # raises: closed or lost

    def _write_ready(self) -> None:
        with self.lock:
            try:
                written = os.write(self._fd, self._pending)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                self._port_lost(exc)
                return
            del self._pending[:written]
            if not self._pending and self._loop is not None:
                self._loop.remove_writer(self._fd)

    # ---- from another thread (push mode) -------------------------------------------------

    def send_from_thread(self, item: bytes) -> bool:
        """Write ``item`` after everything sent before, from a thread that is not the
        loop's; the caller holds :attr:`lock`.  False, writing nothing, once the stream
        is closed or lost.

        Bytes that cannot follow at once are queued as the loop's own would be; the loop
        is asked to watch for writability, and told of a failed write, which loses the
        port as a failed write in the loop does.
        """
        return self._send_in_turn(item, from_thread=True)

    def _send_in_turn(self, item: bytes, *, from_thread: bool) -> bool:
        """Write ``item`` now or queue it behind earlier bytes; False if closed or lost."""
        if self._closed or self._lost is not None:
            return False
        collected = self._collected
        if collected is not None:
            collected += item  # written by _write_collected, in its turn
            return True
        if self._pending:
            self._pending += item  # behind bytes the writability callback is writing
            return True
        loop = self._loop
        assert loop is not None  # push mode
        try:
            written = os.write(self._fd, item)
        except (BlockingIOError, InterruptedError):
            written = 0
        except OSError as exc:
            if from_thread:
                with contextlib.suppress(RuntimeError):  # the loop is closed: nobody to tell
                    loop.call_soon_threadsafe(self._write_failed, exc)
                return True
            self._port_lost(exc)
            raise anyio.BrokenResourceError(
                f"serial port {self.port}: write failed: {exc}"
            ) from exc
        if written < len(item):
            self._pending += item[written:]
            if from_thread:
                with contextlib.suppress(RuntimeError):
                    loop.call_soon_threadsafe(self._watch_writable)
            else:
                loop.add_writer(self._fd, self._write_ready)
        return True

    def _watch_writable(self) -> None:
        """In the loop: write what another thread queued once the port takes it."""
        with self.lock:
            if self._pending and not self._closed and self._lost is None and self._loop:
                self._loop.add_writer(self._fd, self._write_ready)

    def _write_failed(self, exc: OSError) -> None:
        """In the loop: another thread's write failed; the port is lost."""
        with self.lock:
            if not self._closed and self._lost is None:
                self._port_lost(exc)

    # ---- pull mode (any backend) ---------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise anyio.ClosedResourceError
        if self._lost is not None:
            raise anyio.BrokenResourceError(f"serial port {self.port} lost: {self._lost!r}")

    async def receive(self, max_bytes: int = 65536) -> bytes:
        while True:
            self._check_open()
            # Wait first: with VMIN = VTIME = 0 (pyserial's timeout=0) a tty's read
            # returns b"" when empty, which only after readiness means "gone".
            await anyio.wait_readable(self._fd)
            self._check_open()
            try:
                data = os.read(self._fd, max_bytes)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError as exc:
                self._lost = exc
                raise anyio.BrokenResourceError(f"serial port {self.port} lost: {exc}") from exc
            if not data:
                self._lost = anyio.EndOfStream()
                raise anyio.BrokenResourceError(f"serial port {self.port} disconnected")
            return data

    async def send(self, item: bytes) -> None:
        view = memoryview(item)
        while view:
            self._check_open()
            try:
                written = os.write(self._fd, view)
            except (BlockingIOError, InterruptedError):
                await anyio.wait_writable(self._fd)
                continue
            except OSError as exc:
                self._lost = exc
                raise anyio.BrokenResourceError(
                    f"serial port {self.port}: write failed: {exc}"
                ) from exc
            view = view[written:]

    async def send_eof(self) -> None:
        raise NotImplementedError("serial ports have no end-of-file")

    async def aclose(self) -> None:
        if self._closed:
            return
        self.detach()
        with self.lock:
            if self._loop is not None and self._pending:
                self._loop.remove_writer(self._fd)
            self._closed = True
        anyio.notify_closing(self._fd)
        with contextlib.suppress(OSError, serial.SerialException):
            self._serial.close()
        await anyio.lowlevel.checkpoint()


class _ThreadedSerialStream(anyio.abc.ByteStream):
    """Fallback for pyserial URLs without a file descriptor: reads in a worker thread."""

    @property
    def extra_attributes(self) -> Mapping[Any, Callable[[], Any]]:
        """The port's name and baud rate (:class:`LinkAttribute`)."""
        return _line_attributes(self)

    def __init__(self, port: serial.SerialBase) -> None:
        self._serial = port
        self._serial.timeout = 0.05
        self.port = str(port.port)
        self.baudrate: int = int(port.baudrate)
        self._closed = False

    def _broken(self, exc: BaseException) -> Exception:
        if self._closed:  # closed under a read still running in its thread
            return anyio.ClosedResourceError()
        return anyio.BrokenResourceError(f"serial port {self.port} lost: {exc}")

    async def receive(self, max_bytes: int = 65536) -> bytes:
        while True:
            if self._closed:
                raise anyio.ClosedResourceError
            try:
                data: bytes = await anyio.to_thread.run_sync(self._read, max_bytes)
            # ValueError: a socket:// port closed under its ``select`` in ``in_waiting``.
            except (serial.SerialException, OSError, AttributeError, TypeError, ValueError) as exc:
                raise self._broken(exc) from exc
            if data:
                return data

    def _read(self, max_bytes: int) -> bytes:
        waiting = self._serial.in_waiting
        return bytes(self._serial.read(min(max(waiting, 1), max_bytes)))

    async def send(self, item: bytes) -> None:
        if self._closed:
            raise anyio.ClosedResourceError
        try:
            await anyio.to_thread.run_sync(self._serial.write, item)
        except (serial.SerialException, OSError, AttributeError, TypeError, ValueError) as exc:
            raise self._broken(exc) from exc

    async def send_eof(self) -> None:
        raise NotImplementedError("serial ports have no end-of-file")

    async def aclose(self) -> None:
        if self._closed:
            return
        self._closed = True
        await anyio.to_thread.run_sync(self._serial.close)


def _has_fileno(port: serial.SerialBase) -> bool:
    """A POSIX serial port (device or pty) whose descriptor the event loop can watch."""
    return os.name == "posix" and isinstance(getattr(port, "fd", None), int)


async def open_serial_stream(
    url: str, baudrate: int = DEFAULT_BAUD, **serial_options: Any
) -> anyio.abc.ByteStream:
    """Open ``url`` (a device path or any pyserial URL) as a byte stream.

    The port is opened exclusively (pyserial's ``exclusive=True``: an advisory ``flock`` on
    POSIX), so a second program -- ``arduinoio list`` while a robot runs -- cannot steal the
    first one's replies.  Raises :class:`PortBusyError` when another process holds the port
    and :class:`BoardDisconnectedError` when it cannot be opened for any other reason.
    Behind a USB bridge with a latency timer (FTDI) the timer is lowered to 1 ms
    (:func:`~arduinoio_async.transport._latency.tune_link`; a warning says how to allow it
    when it cannot be).  A Mega 2560 (its USB IDs) resets on the open into a bootloader that
    any byte of its first second traps: this returns once that second has passed.
    """
    serial_options.setdefault("exclusive", True)
    try:
        port = serial.serial_for_url(
            url, baudrate=baudrate, timeout=0, write_timeout=0, do_not_open=True, **serial_options
        )
        await anyio.to_thread.run_sync(port.open)
    except _OPEN_ERRORS as exc:
        if "exclusively lock" in str(exc):  # pyserial's wording for a failed flock
            raise PortBusyError(url) from exc
        raise BoardDisconnectedError(f"cannot open {url}: {exc}") from exc
    if not _has_fileno(port):
        return _ThreadedSerialStream(port)
    # The bridge's fastest safe link (an FTDI's 1 ms latency timer); a pty has no bridge.
    # A cancel that came while a worker thread held the open port is taken here, closing
    # the port: returned, it would stay open and locked with nobody to close it.
    try:
        await anyio.to_thread.run_sync(tune_link, url, port.fd)
        # A Mega resets on this open into stk500v2, which a byte in its window traps.
        quiet = await anyio.to_thread.run_sync(port_boot_quiet, url)
        if quiet:
            await anyio.sleep(quiet)
        await anyio.lowlevel.checkpoint_if_cancelled()
    except BaseException:
        with contextlib.suppress(OSError, serial.SerialException):
            port.close()
        raise
    return SerialByteStream(port)
