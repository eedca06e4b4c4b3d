"""Firmware-timed streaming on the virtual Uno (protocol extension)."""

from __future__ import annotations

import itertools
import statistics
import time

import anyio
import pytest

from arduinoio_async import A0, A1, A2, A3, D2, LinkCapacityError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.streaming import Sample

pytestmark = pytest.mark.sim

FOUR = [A0, A1, A2, A3]


def spacing_us(samples: list[Sample]) -> list[int]:
    return [
        (b.board_time_us - a.board_time_us) & 0xFFFFFFFF for a, b in itertools.pairwise(samples)
    ]


async def stream_with_steps(
    board: Board, uno: object, period_ms: float, seconds: float
) -> tuple[list[Sample], list[tuple[float, int]], int, int]:
    """Stream four channels while the fixture steps A0 every 0.5 s; returns samples,
    the (host time, mV) steps, and the stream's gap and drop counts."""
    steps: list[tuple[float, int]] = []
    samples: list[Sample] = []
    async with board.stream(analog=FOUR, period_ms=period_ms, buffer=100_000) as stream:

        async def stepper() -> None:
            for index in range(int(seconds / 0.5)):
                mv = (index * 700) % 5000
                await uno.set_analog(0, mv)  # type: ignore[attr-defined]
                steps.append((time.monotonic(), mv))
                await anyio.sleep(0.5)

        async with anyio.create_task_group() as tg:
            tg.start_soon(stepper)
            end = time.monotonic() + seconds
            async for sample in stream:
                samples.append(sample)
                if sample.host_time >= end:
                    break
    return samples, steps, stream.gaps, stream.dropped


def check_follows_steps(samples: list[Sample], steps: list[tuple[float, int]]) -> None:
    checked = 0
    for (start, mv), (stop, _next) in itertools.pairwise(steps):
        window = [s for s in samples if start + 0.05 <= s.host_time <= stop - 0.02]
        assert window, (start, stop)
        expected = mv * 1024 / 5000
        for sample in window:
            assert abs(sample.analog[A0] - expected) <= 3, (mv, sample)
            checked += 1
    assert checked > 100


async def test_four_channels_at_1ms_for_10s_at_1mbaud(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        samples, steps, gaps, dropped = await stream_with_steps(board, uno, 1.0, 10.0)
    deltas = spacing_us(samples)
    print(
        f"\n1 Mbaud, 4 channels, 1 ms: {len(samples)} samples, gaps {gaps}, dropped {dropped}, "
        f"board spacing {min(deltas)}-{max(deltas)} us (stdev {statistics.pstdev(deltas):.2f})"
    )
    # 10 s of wall time is 10,000 periods only while the simulation keeps real time; on a
    # loaded machine it slows down as a whole, so the board's own clock is the oracle:
    # every period in the samples' span delivered, none lost, none doubled.
    assert len(samples) >= 5000
    span_periods = round((samples[-1].board_time_us - samples[0].board_time_us) / 1000)
    assert len(samples) == span_periods + 1
    assert gaps == 0 and dropped == 0
    sequences = [s.sequence for s in samples]
    assert all((b - a) & 0xFFFF == 1 for a, b in itertools.pairwise(sequences))
    # Timestamps are read in the sampling interrupt: its entry latency is the jitter.
    assert all(abs(d - 1000) <= 20 for d in deltas)
    assert abs(statistics.fmean(deltas) - 1000) < 0.5
    check_follows_steps(samples, steps)


async def test_largest_documented_rate_at_115200(virtual_uno_factory: VirtualUnoFactory) -> None:
    period_us = p.stream_min_period_us(0b1111, p.StreamFlags.NONE, 115200)
    uno = await virtual_uno_factory(board_id=1, baud=115_200)
    async with Board.open(uno.port) as board:
        samples, steps, gaps, dropped = await stream_with_steps(board, uno, period_us / 1000, 3.0)
    deltas = spacing_us(samples)
    print(f"\n115200 baud, 4 channels, {period_us} us: {len(samples)} samples, gaps {gaps}")
    assert gaps == 0 and dropped == 0
    assert all(abs(d - period_us) <= 20 for d in deltas)
    check_follows_steps(samples, steps)


async def test_more_than_the_link_carries_is_refused(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=115_200)
    async with Board.open(uno.port) as board:
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
