"""Software PWM on D2-D7 at 1 us steps, edges by timer compare match.

The fixture captures every pulse with the simulated cycle counter, so the widths are the
board's own, not the host's view of them.
"""

from __future__ import annotations

import statistics
import threading

import anyio
import pytest
import serial

from arduinoio_async import D2, D3, D4, D5, D6, D7, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import SoftPwmPin
from arduinoio_async.sim import PulseStats, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: Distinct, equal and close widths (edges of different pins 8 us apart; closer than ~6 us
#: the later one can be late by up to that, docs/protocol.md).
WIDTHS: dict[SoftPwmPin, int] = {D2: 1000, D3: 1008, D4: 1500, D5: 1500, D6: 1991, D7: 2000}


async def fresh_pulses(uno: VirtualUno, pins: list[int], count: int) -> dict[int, PulseStats]:
    """Clear the captures, then wait until every pin has ``count`` complete pulses."""
    for pin in pins:
        await uno.clear_pulse_stats(pin)
    stats: dict[int, PulseStats] = {}
    with anyio.fail_after(10):
        for pin in pins:
            while (stat := await uno.pulse_stats(pin)).highs < count:  # noqa: ASYNC110 - remote
                await anyio.sleep(0.02)
            stats[pin] = stat
    return stats


async def test_widths_exact_to_a_microsecond_with_the_link_idle(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        for pin, width in WIDTHS.items():
            await board.soft_pwm(pin, pulse_us=width)
        stats = await fresh_pulses(uno, [int(pin) for pin in WIDTHS], 8)
        report = []
        for pin, width in WIDTHS.items():
            stat = stats[int(pin)]
            highs = stat.high_us[-8:]
            report.append(f"D{int(pin)} {width}: {min(highs):.3f}-{max(highs):.3f}")
            assert all(abs(h - width) <= 4 for h in highs), (pin, highs)
            assert max(highs) - min(highs) <= 2, (pin, highs)
            periods = stat.period_us[-6:]
            assert all(abs(t - p.SERVO_PERIOD_US) <= 4 for t in periods), (pin, periods)
        print("\nsoft PWM, link idle (us): " + ", ".join(report))
        # The pulses of one frame start together (the pins are read one after the other, so
        # a later pin's last rise may be a frame or two later).
        rises = [stats[int(pin)].rise_us[-1] for pin in WIDTHS]
        offsets = [(rise - min(rises)) % p.SERVO_PERIOD_US for rise in rises]
        assert all(o < 1 or o > p.SERVO_PERIOD_US - 1 for o in offsets), rises


async def test_one_microsecond_steps_and_stop(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(baud=115_200)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        pwm = await board.soft_pwm(D4, pulse_us=1500)
        for width in (1500, 1501, 1502, 1250):
            await pwm.set_pulse(width)
            stats = await fresh_pulses(uno, [int(D4)], 3)
            # The first capture may still be the previous frame's width.
            assert all(abs(h - width) <= 4 for h in stats[int(D4)].high_us[-2:]), width
        await pwm.set_pulse(0)
        await uno.clear_pulse_stats(D4)
        # No rise for three frames (60 ms of simulated time) once the width is 0.
        start = (await uno.status())["sim_us"]
        with anyio.fail_after(10):
            while (await uno.status())["sim_us"] - start < 3 * p.SERVO_PERIOD_US:  # noqa: ASYNC110
                await anyio.sleep(0.01)  # remote state: simulated time
        assert (await uno.pulse_stats(D4)).count == 0
        assert (await uno.pin(D4)).level == 0


def _hammer(port: str, baud: int, stop: threading.Event, counter: list[int]) -> None:
    """Pipelined GPIO WRITEs to D13, 20 in flight, until ``stop`` (in a worker thread)."""
    request = [p.GpioWrite(int(D13), bool(i)).encode() for i in range(2)]
    with serial.Serial(port, baud, timeout=2) as link:
        link.write(p.GpioConfig(int(D13), p.GpioFlags.OUTPUT).encode())
        link.read(5)
        sent = received = 0
        while not stop.is_set() or received < sent:
            if not stop.is_set() and sent - received < 20:
                link.write(b"".join(request[(sent + i) & 1] for i in range(20 - (sent - received))))
                sent += 20 - (sent - received)
            data = link.read(max(5, link.in_waiting // 5 * 5))
            received += len(data) // 5
        counter.append(received)


@pytest.mark.parametrize("baud", [115_200, 1_000_000])
async def test_widths_under_full_pipelined_load(
    virtual_uno_factory: VirtualUnoFactory, baud: int
) -> None:
    """Receive and transmit interrupts compete with the edge alarm: the widths stay within
    a few microseconds (the spread is printed, the bound asserted is loose)."""
    uno = await virtual_uno_factory(baud=baud)
    async with Board.open(uno.port, baudrate=baud) as board:
        for pin in (D2, D4):
            await board.soft_pwm(pin, pulse_us=1500)
    stop = threading.Event()
    counter: list[int] = []
    async with anyio.create_task_group() as tg:
        tg.start_soon(anyio.to_thread.run_sync, _hammer, uno.port, baud, stop, counter)
        await anyio.sleep(0.2)  # let the load reach its steady state (not a measurement)
        stats = await fresh_pulses(uno, [int(D2), int(D4)], 25)
        stop.set()
    highs = [h for pin in (D2, D4) for h in stats[int(pin)].high_us[-25:]]
    print(
        f"\nsoft PWM 1500 us under pipelined GPIO WRITE at {baud} baud ({counter[0]} writes): "
        f"{min(highs):.3f}-{max(highs):.3f} us, mean {statistics.fmean(highs):.3f}, "
        f"stdev {statistics.pstdev(highs):.3f}"
    )
    assert counter[0] > 100
    assert all(abs(h - 1500) <= 12 for h in highs)
