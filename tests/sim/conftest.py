"""Shared helpers for the virtual Uno harness tests (they use the harness's own test firmware).

The ``virtual_uno_factory`` fixture comes from the top-level conftest's ``pytest_plugins``.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from typing import Any

import anyio
import anyio.abc
import pytest

from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno, find_test_firmware
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import open_serial_stream

__all__ = ["Link", "poll_until", "start_test_board"]

#: Polling interval of the control channel while waiting for a condition.
POLL = 0.002


async def poll_until(check: Callable[[], Awaitable[bool]], what: str, timeout: float = 10) -> None:
    """Poll ``check`` (a control-channel query) until it holds; fail naming ``what``."""
    try:
        with anyio.fail_after(timeout):
            while not await check():  # noqa: ASYNC110 (a query, not an event)
                await anyio.sleep(POLL)
    except TimeoutError:
        pytest.fail(f"timed out after {timeout} s waiting for {what}")


def test_elf(baud: int) -> str:
    """The harness test firmware for ``baud``, or skip when the harness is not built."""
    try:
        return str(find_test_firmware(baud))
    except SimulatorNotAvailable as exc:
        pytest.skip(str(exc))


test_elf.__test__ = False  # type: ignore[attr-defined]


async def start_test_board(factory: VirtualUnoFactory, **options: Any) -> VirtualUno:
    """Start a board running the test firmware at ``options['baud']`` (default 115200)."""
    baud = int(options.setdefault("baud", 115200))
    options.setdefault("elf", test_elf(baud))
    return await factory(**options)


class Link:
    """The test firmware's tiny protocol over an anyio byte stream (no blocking I/O)."""

    def __init__(self, stream: anyio.abc.ByteStream, timeout: float) -> None:
        self.stream = stream
        self.timeout = timeout
        self.pending = bytearray()

    @classmethod
    async def open(cls, uno: VirtualUno, timeout: float = 1.0) -> Link:
        """The board's port at the baud rate its firmware runs at (any other loses bytes)."""
        return cls(await open_serial_stream(uno.port, uno.baud), timeout)

    async def close(self) -> None:
        await self.stream.aclose()

    async def write(self, data: bytes) -> None:
        await self.stream.send(data)

    async def read(self, n: int, timeout: float | None = None) -> bytes:
        """Up to ``n`` bytes: fewer when no more arrive within ``timeout``."""
        with anyio.move_on_after(self.timeout if timeout is None else timeout):
            while len(self.pending) < n:
                self.pending += await self.stream.receive()
        got = bytes(self.pending[:n])
        del self.pending[:n]
        return got

    async def echo_rtt_us(self, byte: int = 0x41) -> float:
        """One echo round trip in microseconds (asserts the echo is correct)."""
        t0 = time.perf_counter()
        await self.write(bytes([byte]))
        got = await self.read(1)
        dt = (time.perf_counter() - t0) * 1e6
        assert got == bytes([byte]), got
        return dt

    async def request(self, data: bytes, reply_len: int) -> bytes:
        await self.write(data)
        got = await self.read(reply_len)
        assert len(got) == reply_len, (data, got)
        return got

    async def pin_mode(self, pin: int, mode: int) -> None:
        """mode: 0 input, 1 input pull-up, 2 output low, 3 output high."""
        assert await self.request(bytes([0x81, pin << 2 | mode]), 1) == b"\x81"

    async def digital_read(self, pin: int) -> int:
        return (await self.request(bytes([0x82, pin]), 1))[0]

    async def adc(self, channel: int) -> int:
        return int.from_bytes(await self.request(bytes([0x83, channel]), 2), "little")

    async def eeprom(self, addr: int) -> int:
        return (await self.request(bytes([0x84, addr]), 1))[0]

    async def uptime_ms(self) -> float:
        return int.from_bytes(await self.request(bytes([0x8A, 0]), 2), "little") * 1.024

    async def wait_answering(self, timeout: float = 5.0) -> None:
        """Echo until the firmware answers (bytes sent before its UART is on are lost)."""
        attempt = 0
        with anyio.fail_after(timeout):
            while True:
                byte = 0x20 + attempt % 0x5F  # a new byte each time: older echoes are skipped
                attempt += 1
                await self.write(bytes([byte]))
                while got := await self.read(1, timeout=0.02):
                    if got[0] == byte:
                        return
