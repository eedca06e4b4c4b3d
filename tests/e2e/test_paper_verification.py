"""The paper's end-to-end verification (Sec. IV) on the virtual Uno and its test circuitry.

Every test drives the real firmware in simavr through the public client API; the fixture
(jumpers, R2R ladders, pulse capture, pulse generator, I2C EEPROM) measures what the
firmware did.
"""

from __future__ import annotations

import random
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from functools import partial
from typing import Any, TypeVar

import anyio
import pytest

from arduinoio_async import (
    A1,
    D2,
    D3,
    D5,
    D9,
    D10,
    BoardError,
    DigitalPin,
)
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import fresh_pulses

pytestmark = pytest.mark.sim

T = TypeVar("T")
PATTERNS = 1000
EVEN = [DigitalPin(n) for n in range(2, 14, 2)]
ODD = [DigitalPin(n) for n in range(3, 14, 2)]


async def gather(calls: list[Callable[[], Awaitable[T]]]) -> list[T]:
    """Run calls concurrently (they pipeline on the link) and return results in order."""
    results: list[Any] = [None] * len(calls)

    async def run(index: int, call: Callable[[], Awaitable[T]]) -> None:
        results[index] = await call()

    async with anyio.create_task_group() as tg:
        for index, call in enumerate(calls):
            tg.start_soon(run, index, call)
    return results


@asynccontextmanager
async def board_on(uno: VirtualUno) -> AsyncIterator[Board]:
    async with Board.open(uno.port, baudrate=uno.baud, timeout=2.0) as board:
        yield board


async def check_jumpers(board: Board, outputs: list[DigitalPin], inputs: list[DigitalPin]) -> None:
    rnd = random.Random(1234 + int(outputs[0]))
    previous = [False] * len(outputs)
    # Inputs first (so no jumper has two drivers), then outputs low, then clear the edges.
    await gather([board.gpio(pin).configure_input for pin in inputs])
    await gather([partial(board.gpio(pin).write, False) for pin in outputs])
    await gather([board.gpio(pin).read for pin in inputs])
    for _ in range(PATTERNS):
        pattern = [rnd.random() < 0.5 for _ in outputs]
        await gather(
            [
                partial(board.gpio(pin).write, level)
                for pin, level in zip(outputs, pattern, strict=True)
            ]
        )
        states = await gather([board.gpio(pin).read for pin in inputs])
        for state, level, before in zip(states, pattern, previous, strict=True):
            assert state.level == level
            assert state.rose == (level and not before)
            assert state.fell == (before and not level)
        previous = pattern


async def test_jumpers_carry_1000_random_patterns_both_ways(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback", baud=1_000_000, fast=True)
    async with board_on(uno) as board:
        await check_jumpers(board, EVEN, ODD)
        await check_jumpers(board, ODD, EVEN)


async def test_r2r_ladders_read_back_random_codes(virtual_uno_factory: VirtualUnoFactory) -> None:
    tolerance = 1.0  # percent, per resistor
    uno = await virtual_uno_factory(
        board_id=1, fixture="r2r", r2r_tolerance=tolerance, baud=1_000_000, fast=True, seed=7
    )
    # Quantisation (1 LSB) plus the worst case of the resistor spread on a 2-bit ladder.
    allowed = 2 + 1024 * 3 * tolerance / 100
    rnd = random.Random(99)
    async with board_on(uno) as board:
        pins = [DigitalPin(n) for n in range(2, 14)]
        for _ in range(200):
            codes = [rnd.randrange(4) for _ in range(6)]
            levels = []
            for code in codes:
                levels += [bool(code & 1), bool(code & 2)]  # B0 = D(2+2k), B1 = D(3+2k)
            await gather(
                [
                    partial(board.gpio(pin).write, level)
                    for pin, level in zip(pins, levels, strict=True)
                ]
            )
            values = await board.read_analog_all()
            for channel, (code, value) in enumerate(zip(codes, values, strict=True)):
                expected = code * 1024 / 4  # Eq. 2: (2*B1 + B0) * VCC / 4
                assert abs(value - expected) <= allowed, (channel, code, value)


async def test_analog_reads_follow_the_fixture_voltage(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fast=True)
    async with board_on(uno) as board:
        for mv in (0, 1250, 2500, 4990):
            await uno.set_analog(1, mv)
            assert abs(await board.analog(A1).read() - mv * 1024 / 5000) <= 2


async def test_edge_flags_latch_short_pulses_between_reads(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with board_on(uno) as board:
        pin = await board.digital_input(D5)
        assert await pin.read() == (False, False, False)
        await uno.drive("D5", 1)
        # A pulse of at least 20 us of simulated time: the harness may run ahead of the
        # wall clock and then hold its time still, so two drives sent back to back could
        # land on one simulated instant, a pulse no pin could see (failed so under load)
        high_from = (await uno.status())["sim_us"]
        with anyio.fail_after(5):
            while (await uno.status())["sim_us"] < high_from + 20:
                pass  # each status round trip lets the harness run
        await uno.drive("D5", 0)
        state = await pin.read()
        assert (state.level, state.rose, state.fell) == (False, True, True)
        assert await pin.read() == (False, False, False)


async def test_servo_pulses_are_measured_by_the_fixture(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with board_on(uno) as board:
        servo = await board.servo(D9, pulse_us=1500)
        other = await board.servo(D10, pulse_us=1000)
        soft = await board.soft_pwm(D2, pulse_us=1700)
        d9, d10, d2 = [await fresh_pulses(uno, pin, 3) for pin in ("D9", "D10", "D2")]
        assert len(d9.high_us) >= 3
        assert all(abs(h - 1500) <= 1 for h in d9.high_us), d9
        assert all(abs(t - 20000) <= 20 for t in d9.period_us), d9
        assert all(abs(h - 1000) <= 1 for h in d10.high_us), d10
        assert d2.high_us and all(abs(h - 1700) <= 100 for h in d2.high_us), d2
        assert all(abs(t - 20000) <= 200 for t in d2.period_us), d2
        await servo.set_pulse(1234)
        await soft.stop()
        d9 = await fresh_pulses(uno, "D9", 2)
        assert all(abs(h - 1234) <= 1 for h in d9.high_us[1:]), d9
        await uno.clear_pulse_stats("D2")
        await fresh_pulses(uno, "D9", 2)  # two servo periods in which D2 must stay low
        assert not (await uno.pulse_stats("D2")).high_us
        assert other.pulse_us == 1000


async def test_counters_count_generated_pulses_exactly(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with board_on(uno) as board:
        rising = await board.counter(D2, edge=p.Edge.RISING)
        falling = await board.counter(D3, edge=p.Edge.FALLING)
        await uno.pulses("D2", count=37, high_us=200, low_us=300)
        await uno.pulses("D3", count=23, high_us=100, low_us=100)
        await uno.wait_pulses()
        assert await rising.read() == 37
        assert await falling.read() == 23
        assert await rising.reset() == 37
        assert await rising.read() == 0


async def test_i2c_eeprom_write_and_read_back(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with board_on(uno) as board:
        bus = await board.i2c(p.I2CSpeed.KHZ_400)
        data = bytes(random.Random(5).randrange(256) for _ in range(16))
        await bus.write(0x50, 0x20, data[:8])
        await bus.write(0x50, 0x28, data[8:])
        assert await bus.read(0x50, 0x20, 16) == data
        assert await uno.eeprom_i2c(0x20, 16) == data
        with pytest.raises(BoardError) as info:
            await bus.read(0x51, 0, 1)
        assert info.value.code is p.ErrorCode.I2C_NACK_ADDRESS


async def test_temperature_follows_the_fixture(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with board_on(uno) as board:
        for celsius in (0.0, 25.0, 60.0):
            await uno.set_temperature(celsius)
            # 1.1 V / 1024 = 1.07 mV per LSB at 1 mV per degree.
            assert abs(await board.temperature() - celsius) <= 2.5


async def test_reset_and_id_written_across_a_reset(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=0x0102)
    async with board_on(uno) as board:
        assert board.board_id == 0x0102
        out = await board.digital_output(D3, initial=True)
        await board.write_id(0x0BEE)
        assert await uno.eeprom(0, 2) == b"\x0b\xee"
        session = board.session
        await board.reset()
        assert board.session != session
        with pytest.raises(BoardError) as info:
            await out.write(False)  # the board forgot the role
        assert info.value.code is p.ErrorCode.PIN_NOT_CONFIGURED
        assert await board.read_id() == 0x0BEE
        await board.restore()
        await out.write(False)
        assert (await uno.pin("D3")).level == 0
