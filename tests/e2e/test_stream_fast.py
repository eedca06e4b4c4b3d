"""Streams below 1 ms: 250 us where the link carries it.

Below 1 ms the board converts with a faster ADC clock (docs/protocol.md); the simulated
ADC is exact at any clock, so the values are checked against the fixture's voltages.
"""

from __future__ import annotations

import functools
import itertools
import operator
import statistics
import time

import anyio
import pytest
import serial

from arduinoio_async import A0, A1, A2, A3, LinkCapacityError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.streaming import Sample
from arduinoio_async.protocol.pins import AnalogPin
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

VOLTS_MV = {A0: 1000, A1: 2000, A2: 3000, A3: 4000}


#: Samples per run: 2 s of simulated time at 250 us (the simulation may run slower than the
#: wall clock on a loaded machine, so runs are counted in samples, not seconds).
COUNT = 8000


async def stream_for(
    board: Board, channels: list[AnalogPin], period_us: int, count: int
) -> tuple[list[Sample], int, int]:
    samples: list[Sample] = []
    with anyio.fail_after(60):
        async with board.stream(
            analog=channels, period_ms=period_us / 1000, buffer=100_000
        ) as stream:
            async for sample in stream:
                samples.append(sample)
                if len(samples) >= count:
                    break
    return samples, stream.gaps, stream.dropped


def check(samples: list[Sample], channels: list[AnalogPin], period_us: int, label: str) -> None:
    deltas = [
        (b.board_time_us - a.board_time_us) & 0xFFFFFFFF for a, b in itertools.pairwise(samples)
    ]
    print(
        f"\n{label}: {len(samples)} samples, board spacing {min(deltas)}-{max(deltas)} us "
        f"(mean {statistics.fmean(deltas):.3f}, stdev {statistics.pstdev(deltas):.2f})"
    )
    sequences = [s.sequence for s in samples]
    assert all((b - a) & 0xFFFF == 1 for a, b in itertools.pairwise(sequences))
    assert all(abs(d - period_us) <= 20 for d in deltas)
    assert abs(statistics.fmean(deltas) - period_us) < 0.5
    for sample in samples:
        for pin in channels:
            assert abs(sample.analog[pin] - VOLTS_MV[pin] * 1024 / 5000) <= 3, (pin, sample)


async def test_three_channels_every_250us_at_1mbaud_without_gaps(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    channels = [A0, A1, A2]
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    for pin, mv in VOLTS_MV.items():
        await uno.set_analog(int(pin), mv)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        samples, gaps, dropped = await stream_for(board, channels, 250, COUNT)
    check(samples, channels, 250, "1 Mbaud, 3 channels, 250 us")
    assert gaps == 0 and dropped == 0


def _read_raw_samples(port: str, baud: int, start: bytes, size: int, count: int) -> list[bytes]:
    """Start a stream and collect its sample frames with bare pyserial (a worker thread)."""
    frames: list[bytes] = []
    with serial.Serial(port, baud, timeout=1) as link:
        link.write(start)
        assert link.read(len(start)) == start  # the echo
        buffer = b""
        end = time.monotonic() + 60
        while len(frames) < count and time.monotonic() < end:
            buffer += link.read(max(1, link.in_waiting))
            while len(buffer) >= size:
                frames.append(buffer[:size])
                buffer = buffer[size:]
    return frames


async def test_four_channels_every_250us_at_2mbaud_without_gaps(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """4,000 frames of 20 bytes a second: read with bare pyserial, so what is measured is the
    board (a Python consumer that falls behind on a loaded machine fills the pty, and the
    harness then drops bytes it cannot hand over)."""
    uno = await virtual_uno_factory(board_id=1, baud=2_000_000)
    for pin, mv in VOLTS_MV.items():
        await uno.set_analog(int(pin), mv)
    start = p.StreamStart(0b1111, p.StreamFlags.NONE, 250).encode()
    frames = await anyio.to_thread.run_sync(
        _read_raw_samples, uno.port, uno.baud, start, 12 + 8, COUNT
    )
    samples = []
    four = [A0, A1, A2, A3]
    for frame in frames:
        # 40 01 MASK FLAGS SEQ(2) T(4) LEN VALUES(8) CS
        assert frame[:4] == bytes([0x40, 0x01, 0x0F, 0x00]) and frame[10] == 8, frame.hex()
        assert functools.reduce(operator.xor, frame) == 0, frame.hex()
        samples.append(
            Sample(
                host_time=0.0,
                board_time_us=int.from_bytes(frame[6:10], "big"),
                sequence=int.from_bytes(frame[4:6], "big"),
                analog={
                    pin: int.from_bytes(frame[11 + 2 * i : 13 + 2 * i])
                    for i, pin in enumerate(four)
                },
            )
        )
    assert len(samples) >= COUNT
    check(samples, four, 250, "2 Mbaud, 4 channels, 250 us (bare pyserial)")


async def test_four_channels_every_250us_is_more_than_1mbaud_carries(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """20-byte frames every 250 us need 80 % of 1 Mbaud; the stream may use 75 %."""
    assert p.stream_min_period_us(0b1111, p.StreamFlags.NONE, 1_000_000) == 300
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(LinkCapacityError):
            async with board.stream(analog=[A0, A1, A2, A3], period_ms=0.25):
                pass
        assert not (await board.status()).flags & p.StatusFlags.STREAMING
        # The shortest period it admits runs without gaps.
        for pin, mv in VOLTS_MV.items():
            await uno.set_analog(int(pin), mv)
        samples, gaps, dropped = await stream_for(board, [A0, A1, A2, A3], 300, COUNT)
    check(samples, [A0, A1, A2, A3], 300, "1 Mbaud, 4 channels, 300 us")
    assert gaps == 0 and dropped == 0


@pytest.mark.parametrize("period_us", [250, 1000, 40_000])
async def test_samples_come_at_the_period_in_simulated_time(
    virtual_uno_factory: VirtualUnoFactory, period_us: int
) -> None:
    """The timestamps are start + whole periods, so they cannot show a wrong period: the
    oracle is the harness's simulated clock (40 ms: more than 65,536 timer counts)."""
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    count = max(20, 200_000 // period_us)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with anyio.fail_after(60):
            # Read before the stream starts: a read after the first sample would come late
            # by however long the host took to see that sample (3 ms once on a loaded CI),
            # and shorten the elapsed time the board's periods must fill.
            start_us = (await uno.status())["sim_us"]
            async with board.stream(analog=[A0], period_ms=period_us / 1000) as stream:
                first = await stream.__anext__()
                for _ in range(count):
                    last = await stream.__anext__()
                end_us = (await uno.status())["sim_us"]
    # Sequence numbers count the board's periods, also across a sample a loaded host lost
    # on the way (the harness drops what a full pty cannot take, as a 16U2's ring would).
    periods = (last.sequence - first.sequence) & 0xFFFF
    assert count <= periods <= count + 5
    # that many periods passed between the two status reads, which bracket the samples:
    # more only by the stream's start (a round trip and the first period) and host latency
    elapsed = end_us - start_us
    assert periods * period_us - 2_000 <= elapsed <= periods * period_us + 6_000 + 2 * period_us


#: Short streams, back to back: before the fix, one stop in 200-300 met a sample being finished.
STOPS = 1000


async def test_no_sample_follows_the_stop_reply_that_counts_it(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """STREAM STOP's reply counts the samples sent before it (its next sequence number).

    A stop that met a sample being finished was answered ahead of that sample: the stream
    counted the sample as lost, and it reached the host after the stream had ended, where
    the next stream took it for its first.  Each short stream must be whole: samples 0, 1,
    2... and no gap, stop after stop.
    """
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        for run in range(STOPS):
            sequences: list[int] = []
            async with board.stream(analog=[A0, A1, A2, A3], period_ms=0.3) as stream:
                async for sample in stream:
                    sequences.append(sample.sequence)
                    if len(sequences) == 10:
                        break
            assert sequences == list(range(10)), (run, sequences)
            assert (stream.gaps, stream.dropped) == (0, 0), run
