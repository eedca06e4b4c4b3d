"""FakeBoard implements every feature it advertises, with the firmware's rules.

Robot code that streams or arms the failsafe must be unit-testable against the fake: these
tests drive it through the public Board API (and, for the watchdog's own timing, through a
bare transport that sends no heartbeats).
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import (
    A0,
    A1,
    A2,
    A3,
    D2,
    D3,
    D4,
    D9,
    BoardError,
    FailsafeTrippedError,
    LinkCapacityError,
    ValueRangeError,
)
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard


async def test_a_stream_on_the_fake_counts_every_sample_and_carries_the_fakes_values() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        fake.analog[:4] = [11, 22, 33, 44]
        counter = await board.counter(D3)
        await board.digital_input(D2)
        sequences = []
        async with board.stream(
            analog=[A0, A1, A2, A3], levels=True, edges=True, counters=True, period_ms=10
        ) as samples:
            assert fake.stream.running
            assert (await board.status()).flags & p.StatusFlags.STREAMING
            fake.drive(2, True)
            fake.drive(3, True)
            async for sample in samples:
                sequences.append(sample.sequence)
                assert [sample.analog[pin] for pin in (A0, A1, A2, A3)] == [11, 22, 33, 44]
                assert sample.rose is not None and sample.counters is not None
                if sample.level(D2) and sample.rose & (1 << 2) and sample.counters == (0, 1):
                    break
            while len(sequences) < 5:
                sequences.append((await samples.__anext__()).sequence)
        assert not fake.stream.running
        assert sequences == list(range(sequences[0], sequences[0] + len(sequences)))
        assert samples.gaps == 0 and samples.dropped == 0
        assert await counter.read() == 1


async def test_the_fake_refuses_a_stream_its_link_cannot_carry() -> None:
    async with FakeBoard(baud=115200) as fake, Board.connect(fake.host_stream) as board:
        with pytest.raises(LinkCapacityError):
            async with board.stream(analog=[A0, A1, A2, A3], counters=True, period_ms=1):
                pass
        assert not fake.stream.running


async def test_a_tripped_fake_applies_safe_states_reports_and_refuses_outputs() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        led = await board.digital_output(D4, initial=True)
        servo = await board.servo(D9, pulse_us=1500)
        await board.arm_failsafe(100, {led: False, servo: 1000})
        assert (await board.status()).flags & p.StatusFlags.FAILSAFE_ARMED
        fired = anyio.Event()
        board.on_failsafe(lambda b: fired.set())
        await fake.expire_failsafe()
        with anyio.fail_after(2):
            await fired.wait()
        assert fake.levels[4] is False and fake.pulses[9] == 1000
        with pytest.raises(FailsafeTrippedError):
            await led.write(True)
        assert (await board.request(p.GpioRead(4))).state == p.GpioState.LOW  # reads work
        await board.rearm_failsafe()
        assert fake.levels[4] is True and fake.pulses[9] == 1500


async def test_the_fakes_watchdog_fires_by_itself_when_the_host_falls_silent() -> None:
    async with FakeBoard() as fake:
        link = await Board.start_link(fake.host_stream)  # a bare link: no heartbeats
        async with link:
            tripped = anyio.Event()
            link.subscribe(lambda event: tripped.set())
            await link.request(p.GpioConfig(4, p.GpioFlags.OUTPUT | p.GpioFlags.INITIAL_HIGH))
            await link.request(p.FailsafeSafeState(4, p.SafeKind.LEVEL, 0))
            await link.request(p.FailsafeArm(p.FAILSAFE_MIN_TIMEOUT_MS))
            with anyio.fail_after(2):
                await tripped.wait()
            assert fake.levels[4] is False
            status = await link.request(p.ReadStatus())
            assert status.flags == p.StatusFlags.FAILSAFE_TRIPPED


async def test_the_fake_checks_failsafe_requests_as_the_firmware_does() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        with pytest.raises(ValueRangeError):
            await board.arm_failsafe(5, {})  # checked before anything is sent
        with pytest.raises(BoardError) as refused:
            await board.request(p.FailsafeArm(5))
        assert refused.value.code == p.ErrorCode.VALUE_OUT_OF_RANGE
        with pytest.raises(BoardError) as refused:  # D8 has no PWM of any kind
            await board.request(p.FailsafeSafeState(8, p.SafeKind.PULSE, 1500))
        assert refused.value.code == p.ErrorCode.PIN_NOT_CAPABLE
        with pytest.raises(BoardError) as refused:
            await board.request(p.FailsafeSafeState(4, p.SafeKind.LEVEL, 2))
        assert refused.value.code == p.ErrorCode.VALUE_OUT_OF_RANGE
        assert not fake.failsafe.armed and not fake.failsafe.safe


@pytest.mark.parametrize(("edge", "expected"), [(p.Edge.RISING, 2), (p.Edge.FALLING, 1)])
async def test_a_fake_counter_counts_only_its_configured_edge(edge: p.Edge, expected: int) -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        counter = await board.counter(D2, edge=edge)
        for level in (True, False, True):
            fake.drive(2, level)
        assert await counter.read() == expected
