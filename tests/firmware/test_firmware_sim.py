"""End-to-end tests of the real firmware (firmware/build/arduinoio-*.elf) on the virtual Uno.

Raw protocol only: frames are built and parsed with the sans-IO core
(:mod:`arduinoio_async.protocol`), the port is an anyio byte stream.  The tests wait on
conditions -- the simulated clock, the harness's byte counters, the fixture's pulse
capture -- never on wall-clock sleeps (the simulator is paced to a noisy wall clock).
Build the firmware with ``make -C firmware`` and the harness with ``make -C firmware/sim``
first; without them these tests are skipped (see ``arduinoio_async.sim.pytest_plugin``).
"""

from __future__ import annotations

import random
from collections.abc import Awaitable, Callable
from typing import Any

import anyio
import anyio.abc
import pytest

from arduinoio_async.protocol import (
    INTER_BYTE_GAP_MS,
    Decoder,
    Frame,
    Garbage,
    StreamSample,
    StreamStopReply,
    checksum,
)
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.transport import open_serial_stream
from arduinoio_async.transport._ready import wait_ready

pytestmark = pytest.mark.sim


def frame(*body: int) -> bytes:
    """``body`` plus its XOR checksum."""
    data = bytes(body)
    return data + bytes((checksum(data),))


def err(ct: int, dt: int, code: int) -> bytes:
    return frame(ct | 0x80, dt, code)


#: Polling interval of the control channel while waiting for a condition.
POLL = 0.002
#: The board discards input after a framing error until the line was quiet this long.
QUIET_US = INTER_BYTE_GAP_MS * 1000 + 1000


async def poll_until(check: Callable[[], Awaitable[bool]], what: str, timeout: float = 10) -> None:
    """Poll ``check`` (a control-channel query) until it holds; fail naming ``what``."""
    try:
        with anyio.fail_after(timeout):
            while not await check():  # noqa: ASYNC110 (a query, not an event)
                await anyio.sleep(POLL)
    except TimeoutError:
        pytest.fail(f"timed out after {timeout} s waiting for {what}")


async def sim_us(uno: VirtualUno) -> float:
    return float((await uno.status())["sim_us"])


async def wait_sim_us(uno: VirtualUno, duration_us: float) -> None:
    """Wait until the simulated board has run ``duration_us`` more (its clock, not ours)."""
    until = await sim_us(uno) + duration_us

    async def passed() -> bool:
        return await sim_us(uno) >= until

    await poll_until(passed, f"{duration_us:g} us of simulated time")


async def wait_line_quiet(uno: VirtualUno) -> None:
    """Wait until the board has seen no host byte for its quiet period (ends a discard)."""

    async def quiet() -> bool:
        status = await uno.status()
        return float(status["sim_us"]) - float(status["last_host_byte_us"]) >= QUIET_US

    await poll_until(quiet, "a quiet line")


async def wait_pulse_count(uno: VirtualUno, pin: int, count: int) -> None:
    async def enough() -> bool:
        return (await uno.pulse_stats(pin)).count >= count

    await poll_until(enough, f"{count} pulses on D{pin}")


class Link:
    """The board's port as an anyio byte stream: no blocking I/O in the event loop."""

    def __init__(self, uno: VirtualUno, stream: anyio.abc.ByteStream) -> None:
        self.uno = uno
        self.stream = stream
        self.pending = bytearray()
        self.received = 0  # every byte from the board since the port opened

    @classmethod
    async def open(cls, uno: VirtualUno) -> Link:
        """Open the port and wait until the firmware answers (it is booting)."""
        stream = await open_serial_stream(uno.port, uno.baud)
        link = cls(uno, stream)
        await wait_ready(stream, deadline=anyio.current_time() + 5, name=uno.port)
        link.received = (await uno.status())["bytes_to_host"]  # wait_ready drained them
        return link

    async def close(self) -> None:
        await self.stream.aclose()

    async def write(self, data: bytes) -> None:
        await self.stream.send(data)

    async def _fill(self) -> None:
        data = await self.stream.receive()
        self.received += len(data)
        self.pending += data

    async def read(self, n: int, timeout: float = 2.0) -> bytes:
        """``n`` bytes, or fewer if they do not come within ``timeout``."""
        with anyio.move_on_after(timeout):
            while len(self.pending) < n:
                await self._fill()
        data = bytes(self.pending[:n])
        del self.pending[:n]
        return data

    async def xfer(self, request: bytes, reply_size: int, timeout: float = 2.0) -> bytes:
        await self.write(request)
        return await self.read(reply_size, timeout)

    async def settle(self, run_us: float = 20_000) -> bytes:
        """Everything the board sent up to ``run_us`` of simulated time from now.

        Counted, not timed: the harness reports how many bytes it passed to the host,
        and this reads until exactly that many have arrived.
        """
        await wait_sim_us(self.uno, run_us)
        sent = (await self.uno.status())["bytes_to_host"]
        with anyio.fail_after(5):
            while self.received < sent:
                await self._fill()
        data = bytes(self.pending)
        self.pending.clear()
        return data

    async def collect(self, enough: Callable[[list[Frame | Garbage]], bool]) -> bytes:
        """Read until the frames received so far satisfy ``enough``."""
        with anyio.fail_after(5):
            while not enough(self.frames(bytes(self.pending))):
                await self._fill()
        data = bytes(self.pending)
        self.pending.clear()
        return data

    def frames(self, data: bytes) -> list[Frame | Garbage]:
        return Decoder.from_board().feed(data)


async def start(factory: VirtualUnoFactory, **options: Any) -> tuple[VirtualUno, Link]:
    uno = await factory(**options)
    return uno, await Link.open(uno)


# The request -> reply behaviour of every command is stated once, in tests/vectors/*.vec,
# and run against the firmware's host tests, this virtual Uno and FakeBoard; the tests
# here cover what those vectors cannot: the circuit's values, timing, streams, resets,
# framing errors and the failsafe's trip.


async def test_table_i_gets_table_ii(virtual_uno_factory: VirtualUnoFactory) -> None:
    _, link = await start(virtual_uno_factory, board_id=0x0102)
    assert await link.xfer(bytes((0x01, 0x02, 0x03)), 5) == bytes((0x01, 0x02, 0x01, 0x02, 0x00))
    await link.close()


async def test_circuit_values_streams_and_reset(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, board_id=0x0102, fast=True)
    await uno.set_analog(2, 2500.0)
    # analog and temperature: the values depend on the simulated voltages
    got = await link.xfer(frame(3, 2, 2), 6)
    assert got[:3] == bytes((3, 2, 2)) and checksum(got) == 0
    assert abs(((got[3] << 8) | got[4]) - 512) <= 2
    got = await link.xfer(frame(3, 3), 15)
    assert got[:2] == bytes((3, 3)) and checksum(got) == 0
    got = await link.xfer(frame(1, 3), 5)
    assert got[:2] == bytes((1, 3)) and checksum(got) == 0
    # stream: start, a few samples, stop; nothing after the stop reply
    assert await link.xfer(frame(7, 1, 0x01, 0x01, 0x27, 0x10), 7) == frame(7, 1, 1, 1, 0x27, 0x10)
    data = await link.collect(lambda fs: sum(isinstance(f, StreamSample) for f in fs) >= 3)
    await link.write(frame(7, 2))
    data += await link.settle()  # everything the board sent, counted by the harness
    frames = link.frames(data)
    samples = [f for f in frames if isinstance(f, StreamSample)]
    stop = [f for f in frames if isinstance(f, StreamStopReply)]
    assert stop and frames[-1] == stop[0]
    assert [s.sequence for s in samples] == list(range(len(samples)))
    assert stop[0].next_sequence == len(samples)
    # reset: reply, then the board restarts (the session tag goes back to 0)
    assert await link.xfer(frame(1, 7, 0x12, 0x34), 5) == frame(1, 7, 0x12, 0x34)
    assert await link.xfer(frame(1, 1), 3) == frame(1, 1)

    async def rebooted() -> bool:
        """Status polls (lost while the board reboots) until a fresh boot answers."""
        reply = await link.xfer(frame(1, 6), 6, timeout=0.05)
        if reply == frame(1, 6, 0, 0, 0):
            return True
        # else nothing, the old session (not reset yet) or the error reply to a request cut
        # by the reboot: let the line settle and ask again
        await link.settle(0)
        await wait_line_quiet(uno)
        return False

    await poll_until(rebooted, "the board to answer after its reset")
    await link.close()


async def test_framing_errors_and_failsafe_trip(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, board_id=7, fast=True)
    # framing errors: one reply, then discard until quiet
    assert await link.xfer(bytes((1, 2, 0x55)), 4) == err(1, 2, 0x01)
    await wait_line_quiet(uno)
    assert await link.xfer(bytes((0x33,)), 4) == frame(0xB3, 0, 0x02)
    await wait_line_quiet(uno)
    assert await link.xfer(bytes((3, 9)), 4) == err(3, 9, 0x03)
    await wait_line_quiet(uno)
    assert await link.xfer(bytes((2, 1, 5)), 4, timeout=1.0) == err(2, 1, 0x04)
    assert await link.xfer(frame(1, 2), 5) == frame(1, 2, 0, 7)
    # failsafe: trip, event, refusal
    assert await link.xfer(frame(2, 1, 13, 3), 5) == frame(2, 1, 13, 3)
    assert await link.xfer(frame(8, 2, 13, 1, 0, 0), 7) == frame(8, 2, 13, 1, 0, 0)
    assert await link.xfer(frame(8, 1, 0, 20), 5) == frame(8, 1, 0, 20)
    assert await link.read(3, timeout=2.0) == frame(0x40, 0x02)
    assert await link.xfer(frame(2, 3, 13, 1), 4) == err(2, 3, 0x0F)
    assert await link.xfer(frame(2, 2, 13), 5) == frame(2, 2, 13, 0)
    assert await link.xfer(frame(1, 6), 6) == frame(1, 6, 2, 0, 0)
    await link.close()


async def test_random_bytes_then_id(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, board_id=0x4242)
    rng = random.Random(1234)
    total = 10_000
    before = (await uno.status())["bytes_from_host"]
    await link.write(bytes(rng.randrange(256) for _ in range(total)))

    async def all_in() -> bool:  # the harness feeds the bytes at the UART's pace
        await link.settle(0)  # keep reading the board's answers meanwhile
        return bool((await uno.status())["bytes_from_host"] >= before + total)

    await poll_until(all_in, "the noise to reach the board", timeout=30)
    await wait_line_quiet(uno)  # the answers to the garbage, then a quiet line
    await link.write(frame(8, 3) + frame(7, 2))  # stop anything the noise started
    await link.settle(100_000)  # a random RESET would have rebooted in ~16 ms
    await wait_line_quiet(uno)
    assert await link.xfer(frame(1, 2), 5) == frame(1, 2, 0x42, 0x42)
    await link.close()


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
    assert await link.xfer(burst, len(want)) == want
    await link.close()


async def test_servo_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory)
    assert await link.xfer(frame(5, 1, 9, 0x05, 0xDC), 6) == frame(5, 1, 9, 0x05, 0xDC)
    await wait_pulse_count(uno, 9, 2)  # running: the first (partial) period is behind
    await uno.clear_pulse_stats(9)
    await wait_pulse_count(uno, 9, 8)
    stats = await uno.pulse_stats(9)
    assert stats.count >= 8
    assert all(abs(h - 1500) <= 1 for h in stats.high_us), stats.high_us
    assert all(abs(p - 20000) <= 1 for p in stats.period_us), stats.period_us
    # 0 holds the line low, a new width comes back cleanly
    assert await link.xfer(frame(5, 2, 9, 0, 0), 6) == frame(5, 2, 9, 0, 0)
    await wait_sim_us(uno, 25_000)  # a pulse begun before the change has ended
    await uno.clear_pulse_stats(9)
    await wait_sim_us(uno, 100_000)  # five periods
    stats = await uno.pulse_stats(9)
    assert stats.count == 0 and stats.level == 0
    await link.close()


async def test_soft_pwm_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory)
    assert await link.xfer(frame(5, 1, 5, 0x05, 0xDC), 6) == frame(5, 1, 5, 0x05, 0xDC)
    assert await link.xfer(frame(5, 1, 7, 0x07, 0xD0), 6) == frame(5, 1, 7, 0x07, 0xD0)
    await wait_pulse_count(uno, 5, 2)
    await wait_pulse_count(uno, 7, 2)
    await uno.clear_pulse_stats(5)
    await uno.clear_pulse_stats(7)
    await wait_pulse_count(uno, 5, 8)
    await wait_pulse_count(uno, 7, 8)
    for pin, width in ((5, 1500), (7, 2000)):
        stats = await uno.pulse_stats(pin)
        assert stats.count >= 8
        assert all(abs(h - width) <= 100 for h in stats.high_us), stats.high_us
        assert all(abs(p - 20000) <= 100 for p in stats.period_us), stats.period_us
    await link.close()


async def test_counters_count_pulses(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, fast=True)
    assert await link.xfer(frame(6, 1, 2, 0), 5) == frame(6, 1, 2, 0)
    assert await link.xfer(frame(6, 1, 3, 1), 5) == frame(6, 1, 3, 1)
    await uno.pulses(2, 1234, 50, 50)
    await uno.pulses(3, 777, 20, 80)
    await uno.wait_pulses()
    assert await link.xfer(frame(6, 2, 2), 8) == frame(6, 2, 2, 0, 0, 0x04, 0xD2)
    assert await link.xfer(frame(6, 3, 3), 8) == frame(6, 3, 3, 0, 0, 0x03, 0x09)
    assert await link.xfer(frame(6, 2, 3), 8) == frame(6, 2, 3, 0, 0, 0, 0)
    await link.close()


async def test_i2c_eeprom_round_trip(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno, link = await start(virtual_uno_factory, fast=True)
    assert await link.xfer(frame(4, 1, 1), 4) == frame(4, 1, 1)
    data = bytes(range(0x30, 0x30 + 16))
    assert await link.xfer(frame(4, 3, 0x50, 0x20, 16, *data), 6) == frame(4, 3, 0x50, 0x20, 16)
    assert await uno.eeprom_i2c(0x20, 16) == data
    assert await link.xfer(frame(4, 2, 0x50, 0x20, 16), 22) == frame(4, 2, 0x50, 0x20, 16, *data)
    await link.close()


async def test_firmware_cycles_per_command(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Simulated CPU cycles from the last request byte to the first reply byte."""
    uno, link = await start(virtual_uno_factory, board_id=1)
    for request in (frame(2, 1, 13, 1), frame(4, 1, 0), frame(2, 1, 8, 0)):
        assert await link.xfer(request, len(request)) == request
    measured: dict[str, tuple[bytes, int]] = {
        "read id": (frame(1, 2), 5),
        "read temperature": (frame(1, 3), 5),
        "capabilities": (frame(1, 4), 15),
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
            assert len(await link.xfer(request, size)) == size, name
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
    await link.close()


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

    async def pwm(dt: int, pin: int, us: int) -> None:
        request = frame(5, dt, pin, us >> 8, us & 0xFF)
        assert await link.xfer(request, 6) == request, (dt, pin, us)

    widths: dict[int, list[int]] = {9: [1500], 10: [1000]}
    await pwm(1, 9, 1500)
    await wait_pulse_count(uno, 9, 2)
    d9 = PulseLog(uno, 9)
    await d9.start()
    await wait_sim_us(uno, 30_000)
    await pwm(1, 10, 1000)  # attaching the other channel must not disturb D9
    await wait_pulse_count(uno, 10, 2)
    d10 = PulseLog(uno, 10)
    await d10.start()
    soft_attached: set[int] = set()
    for step in range(36):
        pin = 9 if step % 2 == 0 else 10
        width = rng.randrange(1000, 2001)
        await pwm(2, pin, width)
        widths[pin].append(width)
        if step % 3 == 0:  # attach, change or release a software PWM pin
            soft = rng.randrange(2, 8)
            if soft in soft_attached and rng.random() < 0.5:
                assert await link.xfer(frame(2, 4, soft), 4) == frame(2, 4, soft)
                soft_attached.discard(soft)
            else:
                await pwm(1, soft, rng.randrange(10, 21) * 100)
                soft_attached.add(soft)
        await wait_sim_us(uno, rng.uniform(3_000, 45_000))  # changes at random phases
        await d9.poll()
        await d10.poll()
    await wait_sim_us(uno, 50_000)
    await d9.poll()
    await d10.poll()
    assert len(d9.period_us) >= 40 and len(d10.period_us) >= 35
    assert_pulse_train(d9, widths[9])
    assert_pulse_train(d10, widths[10])
    await link.close()
