"""Firmware-timed streaming on the virtual Uno (protocol extension)."""

from __future__ import annotations

import itertools
import statistics

import anyio
import pytest

from arduinoio_async import A0, A1, A2, A3, D2, LinkCapacityError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.streaming import Sample
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

FOUR = [A0, A1, A2, A3]


def spacing_us(samples: list[Sample]) -> list[int]:
    return [
        (b.board_time_us - a.board_time_us) & 0xFFFFFFFF for a, b in itertools.pairwise(samples)
    ]


#: The fixture holds each A0 voltage for this much stream time once samples show it.
STEP_S = 0.5
#: A sample matches a commanded voltage within this many LSB.
TOLERANCE = 3


def step_mv(index: int) -> int:
    """Commanded A0 voltages: all different, so a sample names the step it belongs to."""
    return (index * 700) % 5000


def lsb(mv: int) -> float:
    return mv * 1024 / 5000


async def stream_with_steps(
    board: Board, uno: VirtualUno, period_ms: float, steps: int
) -> tuple[list[Sample], list[int], int, int]:
    """Stream four channels while the fixture steps A0; returns the samples, the number of
    samples received before each step was commanded, and the stream's gap and drop counts.

    Paced by the samples, not by a clock: a step is commanded, the stream is read until a
    sample shows it, then ``STEP_S`` worth of samples more, then the next step.
    """
    per_step = round(STEP_S * 1000 / period_ms)
    samples: list[Sample] = []
    commanded: list[int] = []
    await uno.set_analog(0, step_mv(0))
    async with board.stream(analog=FOUR, period_ms=period_ms, buffer=100_000) as stream:
        with anyio.fail_after(steps * STEP_S * 10 + 10):
            for index in range(steps):
                if index:
                    await uno.set_analog(0, step_mv(index))
                commanded.append(len(samples))
                while not samples or abs(samples[-1].analog[A0] - lsb(step_mv(index))) > TOLERANCE:
                    samples.append(await stream.__anext__())
                for _ in range(per_step):
                    samples.append(await stream.__anext__())
    return samples, commanded, stream.gaps, stream.dropped


def check_follows_steps(samples: list[Sample], commanded: list[int]) -> None:
    """Every sample shows one commanded voltage, in the commanded order, and never one
    commanded after the sample was received (no reordering, no stale or invented value)."""
    values = [lsb(step_mv(index)) for index in range(len(commanded))]
    current = 0
    for position, sample in enumerate(samples):
        step = next(
            (
                i
                for i in range(current, len(values))
                if abs(sample.analog[A0] - values[i]) <= TOLERANCE
            ),
            None,
        )
        assert step is not None, (position, sample, "not the current or a later step")
        assert commanded[step] <= position, (position, step, "shown before it was commanded")
        current = step
    assert current == len(values) - 1


async def test_four_channels_at_1ms_for_10s_at_1mbaud(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        samples, commanded, gaps, dropped = await stream_with_steps(board, uno, 1.0, 20)
    deltas = spacing_us(samples)
    print(
        f"\n1 Mbaud, 4 channels, 1 ms: {len(samples)} samples, gaps {gaps}, dropped {dropped}, "
        f"board spacing {min(deltas)}-{max(deltas)} us (stdev {statistics.pstdev(deltas):.2f})"
    )
    assert len(samples) >= 20 * 500
    # every period in the samples' span delivered (the board's clock is the oracle)
    span_periods = round((samples[-1].board_time_us - samples[0].board_time_us) / 1000)
    assert len(samples) == span_periods + 1
    assert gaps == 0 and dropped == 0
    sequences = [s.sequence for s in samples]
    assert all((b - a) & 0xFFFF == 1 for a, b in itertools.pairwise(sequences))
    # Timestamps are read in the sampling interrupt: its entry latency is the jitter.
    assert all(abs(d - 1000) <= 20 for d in deltas)
    assert abs(statistics.fmean(deltas) - 1000) < 0.5
    check_follows_steps(samples, commanded)


async def test_largest_documented_rate_at_115200(virtual_uno_factory: VirtualUnoFactory) -> None:
    period_us = p.stream_min_period_us(0b1111, p.StreamFlags.NONE, 115200)
    uno = await virtual_uno_factory(board_id=1, baud=115_200)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        samples, commanded, gaps, dropped = await stream_with_steps(board, uno, period_us / 1000, 6)
    deltas = spacing_us(samples)
    print(f"\n115200 baud, 4 channels, {period_us} us: {len(samples)} samples, gaps {gaps}")
    assert gaps == 0 and dropped == 0
    assert all(abs(d - period_us) <= 20 for d in deltas)
    check_follows_steps(samples, commanded)


async def test_more_than_the_link_carries_is_refused(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=115_200)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        too_fast = p.stream_min_period_us(0b1111, p.StreamFlags.NONE, 115200) - 100
        with pytest.raises(LinkCapacityError) as info:
            async with board.stream(analog=FOUR, period_ms=too_fast / 1000):
                pass
        assert info.value.code is p.ErrorCode.LINK_CAPACITY
        assert not (await board.status()).flags & p.StatusFlags.STREAMING


async def test_commands_interleave_with_a_running_stream(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0033, baud=1_000_000)
    await uno.set_analog(2, 2500)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        pin = board.gpio(D2)
        async with board.stream(analog=[A0, A1], levels=True, counters=True, period_ms=1) as stream:
            for index in range(200):
                assert await board.read_id() == 0x0033
                await pin.write(bool(index % 2))
                assert (await pin.read()).level == bool(index % 2)
                assert abs(await board.analog(A2).read() - 512) <= 2
            received = 0
            while stream.pending():
                sample = await stream.__anext__()
                assert sample.levels is not None and sample.counters is not None
                received += 1
        assert received > 50
        assert stream.gaps == 0
