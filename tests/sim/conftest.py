"""Shared helpers for the virtual Uno harness tests (they use the harness's own test firmware).

The ``virtual_uno_factory`` fixture comes from the top-level conftest's ``pytest_plugins``.
"""

from __future__ import annotations

import time
from typing import Any

import pytest
import serial

from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno, find_test_firmware
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

__all__ = ["Link", "start_test_board"]


def test_elf(baud: int) -> str:
    """The harness test firmware for ``baud``, or skip when the harness is not built."""
    try:
        return str(find_test_firmware(baud))
    except SimulatorNotAvailable as exc:
        pytest.skip(str(exc))


test_elf.__test__ = False  # type: ignore[attr-defined]


async def start_test_board(factory: VirtualUnoFactory, **options: Any) -> VirtualUno:
    """Start a board running the test firmware at ``options['baud']`` (default 115200)."""
    baud = int(options.get("baud", 115200))
    options.setdefault("elf", test_elf(baud))
    return await factory(**options)


class Link:
    """Blocking pyserial wrapper speaking the test firmware's tiny protocol."""

    def __init__(self, port: str, timeout: float = 1.0) -> None:
        self.ser = serial.Serial(port, timeout=timeout)

    def close(self) -> None:
        self.ser.close()

    def echo_rtt_us(self, byte: int = 0x41) -> float:
        """One echo round trip in microseconds (asserts the echo is correct)."""
        t0 = time.perf_counter()
        self.ser.write(bytes([byte]))
        got = self.ser.read(1)
        dt = (time.perf_counter() - t0) * 1e6
        assert got == bytes([byte]), got
        return dt

    def request(self, data: bytes, reply_len: int) -> bytes:
        self.ser.write(data)
        got = bytes(self.ser.read(reply_len))
        assert len(got) == reply_len, (data, got)
        return got

    def pin_mode(self, pin: int, mode: int) -> None:
        """mode: 0 input, 1 input pull-up, 2 output low, 3 output high."""
        assert self.request(bytes([0x81, pin << 2 | mode]), 1) == b"\x81"

    def digital_read(self, pin: int) -> int:
        return self.request(bytes([0x82, pin]), 1)[0]

    def adc(self, channel: int) -> int:
        return int.from_bytes(self.request(bytes([0x83, channel]), 2), "little")

    def eeprom(self, addr: int) -> int:
        return self.request(bytes([0x84, addr]), 1)[0]

    def uptime_ms(self) -> float:
        return int.from_bytes(self.request(bytes([0x8A, 0]), 2), "little") * 1.024
