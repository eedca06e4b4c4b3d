"""End-to-end tests of the real firmware (firmware/build/arduinoio-*.elf) on the virtual Uno.

Raw protocol only: frames are built and parsed with the sans-IO core
(:mod:`arduinoio_async.protocol`), the port is opened with pyserial.  Build the firmware
with ``make -C firmware`` and the harness with ``make -C firmware/sim`` first; without them
these tests are skipped (see ``arduinoio_async.sim.pytest_plugin``).
"""

from __future__ import annotations

import random
import time
from typing import Any

import anyio
import pytest
import serial

from arduinoio_async.protocol import (
    Decoder,
    Frame,
    Garbage,
    StreamSample,
    StreamStopReply,
    checksum,
)
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


def frame(*body: int) -> bytes:
    """``body`` plus its XOR checksum."""
    data = bytes(body)
    return data + bytes((checksum(data),))


def err(ct: int, dt: int, code: int) -> bytes:
    return frame(ct | 0x80, dt, code)


class Link:
    """Blocking pyserial port to the board."""

    def __init__(self, uno: VirtualUno) -> None:
        self.serial = serial.Serial(uno.port, uno.baud, timeout=0.05)
        self.serial.reset_input_buffer()

    def close(self) -> None:
        self.serial.close()

    def read(self, n: int, timeout: float = 2.0) -> bytes:
        deadline = time.monotonic() + timeout
        data = bytearray()
        while len(data) < n and time.monotonic() < deadline:
            data += self.serial.read(n - len(data))
        return bytes(data)

    def xfer(self, request: bytes, reply_size: int, timeout: float = 2.0) -> bytes:
        self.serial.write(request)
        return self.read(reply_size, timeout)

    def drain(self, quiet: float = 0.05) -> bytes:
        """Everything that arrives until the line has been quiet for ``quiet`` seconds."""
        data = bytearray()
        last = time.monotonic()
        while time.monotonic() - last < quiet:
            chunk = self.serial.read(256)
            if chunk:
                data += chunk
                last = time.monotonic()
        return bytes(data)

    def frames(self, data: bytes) -> list[Frame | Garbage]:
        return Decoder.from_board().feed(data)


async def start(factory: VirtualUnoFactory, **options: Any) -> tuple[VirtualUno, Link]:
    uno = await factory(**options)
    link = Link(uno)
    await anyio.sleep(0.05)  # the firmware boots
    return uno, link


# Request (without CS) -> expected reply (without CS); run in order on one board.
COMMANDS: list[tuple[str, tuple[int, ...], tuple[int, ...]]] = [
    ("id", (1, 2), (1, 2, 0x01, 0x02)),
    ("capabilities", (1, 4), (1, 4, 1, 0, 1, 0x03, 0xFF, 0x00, 0x01, 0xC2, 0x00, 128)),
    ("status", (1, 6), (1, 6, 0, 0, 0)),
    ("set session", (1, 7, 0x12, 0x34), (1, 7, 0x12, 0x34)),
    ("status with session", (1, 6), (1, 6, 0, 0x12, 0x34)),
    ("gpio config output high", (2, 1, 13, 3), (2, 1, 13, 3)),
    ("gpio read output", (2, 2, 13), (2, 2, 13, 1)),
    ("gpio write", (2, 3, 13, 0), (2, 3, 13, 0)),
    ("gpio read after write", (2, 2, 13), (2, 2, 13, 0)),
    ("gpio config input pull-up", (2, 1, 12, 4), (2, 1, 12, 4)),
    ("gpio read pulled up", (2, 2, 12), (2, 2, 12, 1)),
    ("pin release", (2, 4, 12), (2, 4, 12)),
    ("i2c config", (4, 1, 0), (4, 1, 0)),
    ("i2c write", (4, 3, 0x50, 0x08, 2, 0xCA, 0xFE), (4, 3, 0x50, 0x08, 2)),
    ("i2c read", (4, 2, 0x50, 0x08, 2), (4, 2, 0x50, 0x08, 2, 0xCA, 0xFE)),
    ("pwm config servo", (5, 1, 10, 0x05, 0xDC), (5, 1, 10, 0x05, 0xDC)),
    ("pwm set servo", (5, 2, 10, 0x07, 0xD0), (5, 2, 10, 0x07, 0xD0)),
    ("pwm config soft", (5, 1, 6, 0x03, 0xE8), (5, 1, 6, 0x03, 0xE8)),
    ("counter config", (6, 1, 3, 1), (6, 1, 3, 1)),
    ("counter read", (6, 2, 3), (6, 2, 3, 0, 0, 0, 0)),
    ("counter reset", (6, 3, 3), (6, 3, 3, 0, 0, 0, 0)),
    ("failsafe safe state", (8, 2, 13, 1, 0, 1), (8, 2, 13, 1, 0, 1)),
    ("failsafe arm", (8, 1, 0x27, 0x10), (8, 1, 0x27, 0x10)),
    ("status armed", (1, 6), (1, 6, 1, 0x12, 0x34)),
    ("failsafe disarm", (8, 3), (8, 3)),
    ("stream stop (not running)", (7, 2), (7, 2, 0, 0)),
    ("write id", (1, 5, 0xBE, 0xEF), (1, 5, 0xBE, 0xEF)),
    ("id after write", (1, 2), (1, 2, 0xBE, 0xEF)),
]

ERRORS: list[tuple[str, tuple[int, ...], bytes]] = [
    ("not capable", (2, 1, 1, 1), err(2, 1, 0x06)),
    ("not configured", (2, 3, 8, 1), err(2, 3, 0x07)),
    ("value out of range", (2, 1, 8, 0x05), err(2, 1, 0x09)),
    ("analog channel", (3, 2, 6), err(3, 2, 0x06)),
    ("i2c not configured", (4, 2, 0x50, 0, 1), err(4, 2, 0x0D)),
    ("pwm not configured", (5, 2, 9, 0x05, 0xDC), err(5, 2, 0x07)),
    ("pwm out of range", (5, 1, 9, 0x03, 0xE7), err(5, 1, 0x09)),
    ("soft pwm out of range", (5, 1, 2, 0x03, 0xE7), err(5, 1, 0x09)),
    ("counter not capable", (6, 1, 4, 0), err(6, 1, 0x06)),
    ("stream empty", (7, 1, 0, 0, 0x03, 0xE8), err(7, 1, 0x09)),
    ("stream link capacity", (7, 1, 0x3F, 7, 0x03, 0xE8), err(7, 1, 0x0E)),
    ("failsafe timeout", (8, 1, 0, 5), err(8, 1, 0x09)),
]


async def test_table_i_gets_table_ii(virtual_uno_factory: VirtualUnoFactory) -> None:
    _, link = await start(virtual_uno_factory, board_id=0x0102)
    assert link.xfer(bytes((0x01, 0x02, 0x03)), 5) == bytes((0x01, 0x02, 0x01, 0x02, 0x00))
    link.close()


async def test_every_command(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, board_id=0x0102, fast=True)
    await uno.set_analog(2, 2500.0)
    for name, request, reply in COMMANDS:
        want = frame(*reply)
        assert link.xfer(frame(*request), len(want)) == want, name
    # analog and temperature: the values depend on the simulated voltages
    got = link.xfer(frame(3, 2, 2), 6)
    assert got[:3] == bytes((3, 2, 2)) and checksum(got) == 0
    assert abs(((got[3] << 8) | got[4]) - 512) <= 2
    got = link.xfer(frame(3, 3), 15)
    assert got[:2] == bytes((3, 3)) and checksum(got) == 0
    got = link.xfer(frame(1, 3), 5)
    assert got[:2] == bytes((1, 3)) and checksum(got) == 0
    # stream: start, a few samples, stop; nothing after the stop reply
    assert link.xfer(frame(7, 1, 0x01, 0x01, 0x27, 0x10), 7) == frame(7, 1, 1, 1, 0x27, 0x10)
    await anyio.sleep(0.05)
    data = link.xfer(frame(7, 2), 0) + link.drain(0.1)
    frames = link.frames(data)
    samples = [f for f in frames if isinstance(f, StreamSample)]
    stop = [f for f in frames if isinstance(f, StreamStopReply)]
    assert stop and frames[-1] == stop[0]
    assert [s.sequence for s in samples] == list(range(len(samples)))
    assert stop[0].next_sequence == len(samples)
    # reset: reply, then the board restarts (session back to 0)
    assert link.xfer(frame(1, 1), 3) == frame(1, 1)
    await anyio.sleep(0.1)
    assert link.xfer(frame(1, 6), 6) == frame(1, 6, 0, 0, 0)
    link.close()


async def test_error_replies(virtual_uno_factory: VirtualUnoFactory) -> None:
    _, link = await start(virtual_uno_factory, board_id=7, fast=True)
    for name, request, reply in ERRORS:
        assert link.xfer(frame(*request), 4) == reply, name
    # one role per pin
    assert link.xfer(frame(5, 1, 9, 0x05, 0xDC), 6) == frame(5, 1, 9, 0x05, 0xDC)
    assert link.xfer(frame(2, 1, 9, 1), 4) == err(2, 1, 0x08)
    # I2C: nobody at 0x51; A4 busy while the bridge is on
    assert link.xfer(frame(4, 1, 1), 4) == frame(4, 1, 1)
    assert link.xfer(frame(4, 2, 0x51, 0, 1), 4) == err(4, 2, 0x0A)
    assert link.xfer(frame(3, 2, 4), 4) == err(3, 2, 0x08)
    # framing errors: one reply, then discard until quiet
    assert link.xfer(bytes((1, 2, 0x55)), 4) == err(1, 2, 0x01)
    await anyio.sleep(0.03)
    assert link.xfer(bytes((0x33,)), 4) == frame(0xB3, 0, 0x02)
    await anyio.sleep(0.03)
    assert link.xfer(bytes((3, 9)), 4) == err(3, 9, 0x03)
    await anyio.sleep(0.03)
    assert link.xfer(bytes((2, 1, 5)), 4, timeout=1.0) == err(2, 1, 0x04)
    assert link.xfer(frame(1, 2), 5) == frame(1, 2, 0, 7)
    # failsafe: trip, event, refusal
    assert link.xfer(frame(2, 1, 13, 3), 5) == frame(2, 1, 13, 3)
    assert link.xfer(frame(8, 2, 13, 1, 0, 0), 7) == frame(8, 2, 13, 1, 0, 0)
    assert link.xfer(frame(8, 1, 0, 20), 5) == frame(8, 1, 0, 20)
    assert link.read(3, timeout=2.0) == frame(0x40, 0x02)
    assert link.xfer(frame(2, 3, 13, 1), 4) == err(2, 3, 0x0F)
    assert link.xfer(frame(2, 2, 13), 5) == frame(2, 2, 13, 0)
    assert link.xfer(frame(1, 6), 6) == frame(1, 6, 2, 0, 0)
    link.close()


async def test_random_bytes_then_id(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, board_id=0x4242)
    rng = random.Random(1234)
    total = 10_000
    link.serial.write(bytes(rng.randrange(256) for _ in range(total)))
    # the harness feeds the bytes at the UART's pace: wait until all are in the board
    deadline = time.monotonic() + 10
    while (await uno.status())["bytes_from_host"] < total and time.monotonic() < deadline:
        link.drain(0.0)
        await anyio.sleep(0.05)
    link.drain(0.05)  # the board's answers to the garbage, then more than 10 ms of quiet
    link.serial.write(frame(8, 3) + frame(7, 2))  # stop anything the noise started
    link.drain(0.05)
    await anyio.sleep(0.1)  # a random RESET would reboot in ~16 ms
    link.drain(0.05)
    assert link.xfer(frame(1, 2), 5) == frame(1, 2, 0x42, 0x42)
    link.close()


async def test_pipelined_requests_in_order(virtual_uno_factory: VirtualUnoFactory) -> None:
    _, link = await start(virtual_uno_factory, board_id=9, fast=True)
    requests = [
        (frame(2, 1, 13, 1), frame(2, 1, 13, 1)),
        (frame(1, 2), frame(1, 2, 0, 9)),
        (frame(2, 3, 13, 1), frame(2, 3, 13, 1)),
        (frame(2, 2, 13), frame(2, 2, 13, 1)),
        (frame(2, 3, 5, 1), err(2, 3, 0x07)),
        (frame(1, 7, 0, 1), frame(1, 7, 0, 1)),
        (frame(1, 6), frame(1, 6, 0, 0, 1)),
    ] * 3
    burst = b"".join(r for r, _ in requests)
    assert len(burst) <= 128
    want = b"".join(w for _, w in requests)
    assert link.xfer(burst, len(want)) == want
    link.close()


async def test_servo_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory)
    assert link.xfer(frame(5, 1, 9, 0x05, 0xDC), 6) == frame(5, 1, 9, 0x05, 0xDC)
    await anyio.sleep(0.1)
    await uno.clear_pulse_stats(9)
    await anyio.sleep(0.25)
    stats = await uno.pulse_stats(9)
    assert stats.count >= 8
    assert all(abs(h - 1500) <= 1 for h in stats.high_us), stats.high_us
    assert all(abs(p - 20000) <= 1 for p in stats.period_us), stats.period_us
    # 0 holds the line low, a new width comes back cleanly
    assert link.xfer(frame(5, 2, 9, 0, 0), 6) == frame(5, 2, 9, 0, 0)
    await anyio.sleep(0.05)
    await uno.clear_pulse_stats(9)
    await anyio.sleep(0.1)
    stats = await uno.pulse_stats(9)
    assert stats.count == 0 and stats.level == 0
    link.close()


async def test_soft_pwm_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory)
    assert link.xfer(frame(5, 1, 5, 0x05, 0xDC), 6) == frame(5, 1, 5, 0x05, 0xDC)
    assert link.xfer(frame(5, 1, 7, 0x07, 0xD0), 6) == frame(5, 1, 7, 0x07, 0xD0)
    await anyio.sleep(0.1)
    await uno.clear_pulse_stats(5)
    await uno.clear_pulse_stats(7)
    await anyio.sleep(0.25)
    for pin, width in ((5, 1500), (7, 2000)):
        stats = await uno.pulse_stats(pin)
        assert stats.count >= 8
        assert all(abs(h - width) <= 100 for h in stats.high_us), stats.high_us
        assert all(abs(p - 20000) <= 100 for p in stats.period_us), stats.period_us
    link.close()


async def test_counters_count_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, fast=True)
    assert link.xfer(frame(6, 1, 2, 0), 5) == frame(6, 1, 2, 0)
    assert link.xfer(frame(6, 1, 3, 1), 5) == frame(6, 1, 3, 1)
    await uno.pulses(2, 1234, 50, 50)
    await uno.pulses(3, 777, 20, 80)
    await uno.wait_pulses()
    assert link.xfer(frame(6, 2, 2), 8) == frame(6, 2, 2, 0, 0, 0x04, 0xD2)
    assert link.xfer(frame(6, 3, 3), 8) == frame(6, 3, 3, 0, 0, 0x03, 0x09)
    assert link.xfer(frame(6, 2, 3), 8) == frame(6, 2, 3, 0, 0, 0, 0)
    link.close()


async def test_i2c_eeprom_round_trip(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, fast=True)
    assert link.xfer(frame(4, 1, 1), 4) == frame(4, 1, 1)
    data = bytes(range(0x30, 0x30 + 16))
    assert link.xfer(frame(4, 3, 0x50, 0x20, 16, *data), 6) == frame(4, 3, 0x50, 0x20, 16)
    assert await uno.eeprom_i2c(0x20, 16) == data
    assert link.xfer(frame(4, 2, 0x50, 0x20, 16), 22) == frame(4, 2, 0x50, 0x20, 16, *data)
    link.close()


async def test_firmware_cycles_per_command(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Simulated CPU cycles from the last request byte to the first reply byte."""
    uno, link = await start(virtual_uno_factory, board_id=1)
    setup = [frame(2, 1, 13, 1), frame(4, 1, 0), frame(2, 1, 8, 0)]
    for request in setup:
        link.serial.write(request)
        link.drain(0.05)
    measured: dict[str, tuple[bytes, int]] = {
        "read id": (frame(1, 2), 5),
        "read temperature": (frame(1, 3), 5),
        "capabilities": (frame(1, 4), 13),
        "status": (frame(1, 6), 6),
        "gpio write": (frame(2, 3, 13, 1), 5),
        "gpio read": (frame(2, 2, 8), 5),
        "analog read": (frame(3, 2, 0), 6),
        "analog read all": (frame(3, 3), 15),
        "i2c write 1": (frame(4, 3, 0x50, 0, 1, 1), 6),
        "i2c write 4": (frame(4, 3, 0x50, 0, 4, 1, 2, 3, 4), 6),
        "i2c read 1": (frame(4, 2, 0x50, 0, 1), 7),
        "i2c read 4": (frame(4, 2, 0x50, 0, 4), 10),
    }
    results: dict[str, int] = {}
    for name, (request, size) in measured.items():
        samples = []
        for _ in range(3):  # the smallest of three: the 100 us tick may land in one
            await uno.firmware_cycles(clear=True)
            assert len(link.xfer(request, size)) == size, name
            cycles = await uno.firmware_cycles()
            assert cycles.last is not None
            samples.append(cycles.last)
        results[name] = min(samples)
    for name, count in results.items():
        print(f"firmware cycles {name}: {count} ({count / 16:.1f} us)")
    assert max(results.values()) < 16 * 10_000  # every reply starts within 10 ms
    # the plain commands are a few hundred cycles from the last byte to the first reply byte
    for name in ("read id", "status", "gpio write", "gpio read", "capabilities"):
        assert results[name] < 1000, (name, results[name])
    link.close()


class PulseLog:
    """Every pulse on one pin since the log started, from polls of the fixture's capture."""

    def __init__(self, uno: VirtualUno, pin: int) -> None:
        self.uno = uno
        self.pin = pin
        self.high_us: list[float] = []
        self.period_us: list[float] = []

    async def start(self) -> None:
        await self.uno.clear_pulse_stats(self.pin)

    async def poll(self) -> None:
        stats = await self.uno.pulse_stats(self.pin)
        new_high = stats.highs - len(self.high_us)
        new_period = stats.periods - len(self.period_us)
        # the capture keeps 32 values: poll often enough that none was overwritten
        assert 0 <= new_high <= len(stats.high_us), (self.pin, stats)
        assert 0 <= new_period <= len(stats.period_us), (self.pin, stats)
        self.high_us += stats.high_us[len(stats.high_us) - new_high :]
        self.period_us += stats.period_us[len(stats.period_us) - new_period :]


def assert_pulse_train(log: PulseLog, widths: list[int]) -> None:
    """Each pulse has one of the commanded widths (+/- 1 us), in the commanded order (a
    width may be skipped when it was replaced within one period), and every period is
    20 ms +/- 2 us (so no pulse is missing, doubled or shifted)."""
    assert log.high_us, log.pin
    index = 0
    for n, high in enumerate(log.high_us):
        if abs(high - widths[index]) <= 1:
            continue
        later = [i for i in range(index + 1, len(widths)) if abs(high - widths[i]) <= 1]
        assert later, f"D{log.pin} pulse {n}: {high} us, expected one of {widths[index:]}"
        index = later[0]
    bad = [(n, t) for n, t in enumerate(log.period_us) if abs(t - 20000) > 2]
    assert not bad, f"D{log.pin} periods off: {bad}"


async def test_servo_width_changes_never_disturb_pulses(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Width changes on D9/D10, attaching D10 and soft PWM pins: no pulse on D9/D10 is ever
    longer or shorter than the old or new width, and the 20 ms period never moves."""
    uno, link = await start(virtual_uno_factory)
    rng = random.Random(99)

    def pwm(dt: int, pin: int, us: int) -> None:
        request = frame(5, dt, pin, us >> 8, us & 0xFF)
        assert link.xfer(request, 6) == request, (dt, pin, us)

    widths: dict[int, list[int]] = {9: [1500], 10: [1000]}
    pwm(1, 9, 1500)
    await anyio.sleep(0.06)
    d9 = PulseLog(uno, 9)
    await d9.start()
    await anyio.sleep(0.03)
    pwm(1, 10, 1000)  # attaching the other channel must not disturb D9
    await anyio.sleep(0.05)
    d10 = PulseLog(uno, 10)
    await d10.start()
    soft_attached: set[int] = set()
    for step in range(36):
        pin = 9 if step % 2 == 0 else 10
        width = rng.randrange(1000, 2001)
        pwm(2, pin, width)
        widths[pin].append(width)
        if step % 3 == 0:  # attach, change or release a software PWM pin
            soft = rng.randrange(2, 8)
            if soft in soft_attached and rng.random() < 0.5:
                assert link.xfer(frame(2, 4, soft), 4) == frame(2, 4, soft)
                soft_attached.discard(soft)
            else:
                pwm(1, soft, rng.randrange(10, 21) * 100)
                soft_attached.add(soft)
        await anyio.sleep(rng.uniform(0.003, 0.045))
        await d9.poll()
        await d10.poll()
    await anyio.sleep(0.05)
    await d9.poll()
    await d10.poll()
    assert len(d9.period_us) >= 40 and len(d10.period_us) >= 35
    assert_pulse_train(d9, widths[9])
    assert_pulse_train(d10, widths[10])
    link.close()
