"""The transport against a fault-injecting in-memory board.

Invariant in every case: each call returns its own correct answer or raises a documented
exception, and nothing hangs.
"""

from __future__ import annotations

import logging
import os
from typing import Any

import anyio
import anyio.abc
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from arduinoio_async import protocol as p
from arduinoio_async.errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    BoardTimeoutError,
    LinkError,
)
from arduinoio_async.testing import FakeBoard, Faults
from arduinoio_async.transport import LinkState, TraceRecord, Transport, open_serial_stream

FAST: dict[str, Any] = {"timeout": 0.2, "quiet_time": 0.005}


def make_fake(faults: Faults | None = None) -> FakeBoard:
    fake = FakeBoard(board_id=0x0102, faults=faults or Faults())
    fake.analog = [100 * ch + 7 for ch in range(6)]
    fake.i2c_devices[0x50][:] = bytes(range(256))
    fake.temperature_raw = 293
    fake.i2c_speed = p.I2CSpeed.KHZ_100
    return fake


def expected(fake: FakeBoard, request: p.Request[p.Reply]) -> p.Reply:
    """What a correct board answers; the fake's state is static for these reads."""
    if isinstance(request, p.ReadId):
        return p.ReadIdReply(0x0102)
    if isinstance(request, p.AnalogRead):
        return p.AnalogReadReply(request.channel, 100 * request.channel + 7)
    if isinstance(request, p.AnalogReadAll):
        return p.AnalogReadAllReply(tuple(100 * ch + 7 for ch in range(6)))
    if isinstance(request, p.ReadTemperature):
        return p.ReadTemperatureReply(293)
    if isinstance(request, p.I2CRead):
        data = bytes((request.register + i) % 256 for i in range(request.length))
        return p.I2CReadReply(0x50, request.register, data)
    raise AssertionError(request)


read_requests = st.one_of(
    st.just(p.ReadId()),
    st.builds(p.AnalogRead, channel=st.integers(0, 3)),
    st.just(p.AnalogReadAll()),
    st.just(p.ReadTemperature()),
    st.builds(
        p.I2CRead, address=st.just(0x50), register=st.integers(0, 255), length=st.integers(1, 32)
    ),
)


async def test_a_request_gets_its_reply() -> None:
    async with make_fake() as fake, Transport(fake.host_stream, **FAST) as link:
        reply = await link.request(p.ReadId())
        assert reply == p.ReadIdReply(0x0102)
        assert await link.request(p.AnalogRead(3)) == p.AnalogReadReply(3, 307)


async def test_error_replies_raise_board_errors_and_keep_the_link() -> None:
    async with make_fake() as fake, Transport(fake.host_stream, **FAST) as link:
        with pytest.raises(BoardError) as info:
            await link.request(p.GpioWrite(pin=4, value=True))
        assert info.value.code is p.ErrorCode.PIN_NOT_CONFIGURED
        with pytest.raises(BoardError) as info:
            await link.request(p.I2CRead(0x51, 0, 1))
        assert info.value.code is p.ErrorCode.I2C_NACK_ADDRESS
        assert link.state is LinkState.READY
        assert link.stats.resyncs == 0


async def test_pipelined_requests_each_get_their_own_reply() -> None:
    async with (
        make_fake(Faults(split=True, seed=3)) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        results: dict[int, p.Reply] = {}
        most_in_flight = 0

        async def one(i: int) -> None:
            nonlocal most_in_flight
            request = p.AnalogRead(i % 4)
            results[i] = await link.request(request)
            assert results[i] == expected(fake, request)

        def watch(record: TraceRecord) -> None:
            nonlocal most_in_flight
            most_in_flight = max(most_in_flight, link.in_flight)

        link.trace = watch
        async with anyio.create_task_group() as tg:
            for i in range(60):
                tg.start_soon(one, i)
        assert len(results) == 60
        assert most_in_flight > 5


async def test_the_window_bounds_request_bytes_in_flight() -> None:
    async with (
        make_fake(Faults(delay=(0.001, 0.002))) as fake,
        Transport(fake.host_stream, window_bytes=16, **FAST) as link,
    ):
        peak = 0

        def watch(record: TraceRecord) -> None:
            nonlocal peak
            peak = max(peak, link.in_flight_bytes)

        link.trace = watch
        async with anyio.create_task_group() as tg:
            for i in range(20):
                tg.start_soon(link.request, p.AnalogRead(i % 4))
        assert 0 < peak <= 16


async def test_a_reply_that_never_comes_times_out_and_the_link_recovers() -> None:
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        with pytest.raises(BoardTimeoutError):
            await link.request(p.AnalogRead(1))
        fake.faults.lose_reply = 0.0
        assert await link.request(p.AnalogRead(2)) == p.AnalogReadReply(2, 207)
        assert link.stats.resyncs >= 1


async def test_a_late_reply_is_never_delivered_to_the_next_caller() -> None:
    async with (
        make_fake(Faults(delay=(0.3, 0.3))) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        with pytest.raises(BoardTimeoutError):
            await link.request(p.AnalogRead(1), timeout=0.1)
        fake.faults.delay = (0.0, 0.0)
        # The late AnalogRead(1) reply arrives while this one waits: it must be dropped.
        for channel in (2, 3, 0):
            assert await link.request(p.AnalogRead(channel), timeout=1.0) == expected(
                fake, p.AnalogRead(channel)
            )


async def test_unplugging_fails_pending_requests_at_once() -> None:
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, timeout=30.0, quiet_time=0.005) as link,
    ):
        outcome: list[BaseException] = []

        async def waiter() -> None:
            try:
                await link.request(p.ReadId())
            except ArduinoIOError as exc:
                outcome.append(exc)

        with anyio.fail_after(5):  # a hang guard, far below the 30 s request timeout
            async with anyio.create_task_group() as tg:
                tg.start_soon(waiter)
                await anyio.wait_all_tasks_blocked()
                await fake.unplug()
        assert isinstance(outcome[0], BoardDisconnectedError)
        with pytest.raises(BoardDisconnectedError):
            await link.request(p.ReadId())
        assert link.state is LinkState.CLOSED


async def test_closing_the_transport_fails_pending_requests() -> None:
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, timeout=30.0) as link,
    ):
        errors: list[BaseException] = []

        async def waiter() -> None:
            try:
                await link.request(p.ReadId())
            except ArduinoIOError as exc:
                errors.append(exc)

        with anyio.fail_after(5):
            async with anyio.create_task_group() as tg:
                tg.start_soon(waiter)
                await anyio.wait_all_tasks_blocked()
                await link.aclose()
        assert isinstance(errors[0], BoardDisconnectedError)


async def test_a_different_board_after_resync_closes_the_link() -> None:
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        link.expected_id = 0x0102
        fake.board_id = 0x0999
        with pytest.raises(BoardTimeoutError):
            await link.request(p.AnalogRead(0))
        fake.faults.lose_reply = 0.0
        with anyio.fail_after(5), pytest.raises(BoardDisconnectedError, match="0x0999"):
            while True:
                try:
                    await link.request(p.AnalogRead(0))
                except BoardTimeoutError:
                    continue


async def test_stream_events_go_to_subscribers_not_to_callers() -> None:
    async with make_fake() as fake, Transport(fake.host_stream, **FAST) as link:
        seen: list[p.Event] = []
        link.subscribe(seen.append)
        sample = p.StreamSample(1, p.StreamFlags.NONE, 5, 1000, b"\x01\x02")
        await fake.push(sample)
        assert await link.request(p.ReadId()) == p.ReadIdReply(0x0102)
        assert seen == [sample]


# ---- property-based: faults, concurrency and cancellation ---------------------------------

fault_configs = st.builds(
    Faults,
    seed=st.integers(0, 2**16),
    split=st.booleans(),
    garbage=st.sampled_from([0.0, 0.05, 0.2]),
    drop_byte=st.sampled_from([0.0, 0.01, 0.05]),
    insert_byte=st.sampled_from([0.0, 0.01, 0.05]),
    flip_byte=st.sampled_from([0.0, 0.01, 0.05]),
    lose_reply=st.sampled_from([0.0, 0.02, 0.1]),
    delay=st.sampled_from([(0.0, 0.0), (0.0, 0.002), (0.0, 0.06)]),
)

FAULT_CASES = 150


class RecordingStream(anyio.abc.ByteStream):
    """The host's end of the fake's link, keeping every byte the host received."""

    def __init__(self, inner: anyio.abc.ByteStream) -> None:
        self.inner = inner
        self.received = bytearray()

    async def receive(self, max_bytes: int = 65536) -> bytes:
        data = await self.inner.receive(max_bytes)
        self.received += data
        return data

    async def send(self, item: bytes) -> None:
        await self.inner.send(item)

    async def send_eof(self) -> None:
        await self.inner.send_eof()

    async def aclose(self) -> None:
        await self.inner.aclose()


def check_undetected_corruption(
    fake: FakeBoard, wire: RecordingStream, request: p.Request[p.Reply], reply: p.Reply
) -> None:
    """A wrong value is acceptable only as a corrupt frame the checksum cannot see.

    An 8-bit XOR passes one corrupt frame in 256, so the oracle cannot demand the right
    value under faults; it demands that the wrong one could only come that way: the faults
    corrupted a reply, the frame echoes *this* request (never another caller's answer),
    and its bytes are ones the host really received (nothing invented by the decoder).
    """
    assert fake.corrupted_replies > 0, (request, reply)
    assert request.matches(reply), (request, reply)
    assert reply.encode() in wire.received, (request, reply)


@settings(
    max_examples=FAULT_CASES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    faults=fault_configs,
    calls=st.lists(
        st.tuples(read_requests, st.one_of(st.none(), st.floats(0.0, 0.02))),
        min_size=1,
        max_size=12,
    ),
)
@pytest.mark.parametrize("backend", ["asyncio", "trio"])
def test_every_call_gets_its_own_answer_or_a_documented_error(
    backend: str, faults: Faults, calls: list[tuple[p.Request[p.Reply], float | None]]
) -> None:
    """Concurrent calls over a faulty link; some are cancelled after a random delay."""

    async def scenario() -> None:
        fake = make_fake(faults)
        wire = RecordingStream(fake.host_stream)
        async with fake, Transport(wire, timeout=0.1, quiet_time=0.005) as link:
            outcomes: list[str] = []

            async def call(request: p.Request[p.Reply], cancel_after: float | None) -> None:
                with anyio.CancelScope() as scope:
                    if cancel_after is not None:
                        scope.deadline = anyio.current_time() + cancel_after
                    try:
                        reply = await link.request(request)
                    except (LinkError, BoardError) as exc:
                        assert not isinstance(exc, BoardError), exc  # reads never fail
                        outcomes.append(type(exc).__name__)
                        return
                    if reply != expected(fake, request):
                        check_undetected_corruption(fake, wire, request, reply)
                    outcomes.append("ok")
                if scope.cancelled_caught:
                    outcomes.append("cancelled")

            with anyio.fail_after(20):
                async with anyio.create_task_group() as tg:
                    for request, cancel_after in calls:
                        tg.start_soon(call, request, cancel_after)
                assert len(outcomes) == len(calls)
                # Whatever happened, the link comes back: a clean board answers again.
                faults.garbage = faults.drop_byte = faults.insert_byte = 0.0
                faults.flip_byte = faults.lose_reply = 0.0
                faults.delay = (0.0, 0.0)
                while True:
                    try:
                        assert await link.request(p.ReadId(), timeout=0.5) == p.ReadIdReply(0x0102)
                        break
                    except LinkError:
                        continue

    anyio.run(scenario, backend=backend)


# ---- the link core: order, matching, timeouts --------------------------------------------


async def test_wire_order_is_call_order_across_many_tasks() -> None:
    """32 tasks toggle one pin; every call takes the next level when it is made.  The
    board must see the levels in call order (the landed code let queued callers race for
    the window and reordered some)."""
    async with (
        make_fake(Faults(delay=(0.0, 0.0005), seed=5)) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        await link.request(p.GpioConfig(2, p.GpioFlags.OUTPUT))
        called: list[bool] = []
        on_wire: list[bool] = []

        def watch(record: TraceRecord) -> None:
            if record.direction == "tx" and isinstance(record.item, p.GpioWrite):
                on_wire.append(record.item.value)

        link.trace = watch
        level = False

        async def toggler() -> None:
            nonlocal level
            for _ in range(20):
                level = not level
                called.append(level)
                await link.request(p.GpioWrite(2, level))

        async with anyio.create_task_group() as tg:
            for _ in range(32):
                tg.start_soon(toggler)
        assert on_wire == called
        assert len(called) == 640


async def test_a_failing_subscriber_is_logged_and_the_link_keeps_working(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async with make_fake() as fake, Transport(fake.host_stream, **FAST) as link:
        seen: list[p.Event] = []

        def buggy(event: p.Event) -> None:
            raise IndexError("consumer bug")

        link.subscribe(buggy)
        link.subscribe(seen.append)
        sample = p.StreamSample(1, p.StreamFlags.NONE, 5, 1000, b"\x01\x02")
        await fake.push(sample)
        assert await link.request(p.ReadId()) == p.ReadIdReply(0x0102)
        assert seen == [sample]
        assert link.state is LinkState.READY
        assert "consumer bug" in caplog.text


async def test_losing_sync_is_logged_with_its_reason(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="arduinoio_async")
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, **FAST) as link,
    ):
        with pytest.raises(BoardTimeoutError):
            await link.request(p.AnalogRead(1))
        fake.faults.lose_reply = 0.0
        assert await link.request(p.AnalogRead(2)) == p.AnalogReadReply(2, 207)
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert any("AnalogRead timed out" in r.getMessage() for r in warnings)
    assert any("in sync again" in r.getMessage() for r in caplog.records)


async def test_an_unplugged_serial_port_fails_requests_quietly(
    capfd: pytest.CaptureFixture[str],
) -> None:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    try:
        stream = await open_serial_stream(path)
        async with Transport(stream, timeout=2.0, name=path) as link:
            os.close(master)  # the cable is pulled
            with anyio.fail_after(5):
                for _ in range(3):
                    with pytest.raises(BoardDisconnectedError):
                        await link.request(p.ReadId())
            assert link.state is LinkState.CLOSED
    finally:
        os.close(slave)
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Fatal" not in err, err


async def test_a_queued_request_that_expires_unsent_costs_no_resync() -> None:
    async with (
        make_fake(Faults(lose_reply=1.0)) as fake,
        Transport(fake.host_stream, window_bytes=3, timeout=5.0, quiet_time=0.005) as link,
        anyio.create_task_group() as tg,
    ):
        tg.start_soon(link.request, p.ReadId())  # fills the window, never answered
        with anyio.fail_after(5):
            while link.in_flight == 0:
                await anyio.wait_all_tasks_blocked()
        with pytest.raises(BoardTimeoutError, match="unsent"):
            await link.request(p.ReadId(), timeout=0.01)
        assert link.stats.resyncs == 0 and link.state is LinkState.READY
        assert link.in_flight == 1
        tg.cancel_scope.cancel()


def test_the_fault_oracle_rejects_answers_no_corruption_explains() -> None:
    """The oracle above can fail: after a corrupted reply it still refuses another
    caller's answer and a value the host never received."""
    fake = make_fake()
    fake.corrupted_replies = 1
    wire = RecordingStream(fake.host_stream)
    request = p.AnalogRead(2)
    corrupt = p.AnalogReadReply(2, 999)
    wire.received += corrupt.encode()
    check_undetected_corruption(fake, wire, request, corrupt)  # explained: accepted
    with pytest.raises(AssertionError):  # another caller's answer
        check_undetected_corruption(fake, wire, request, p.AnalogReadReply(1, 107))
    with pytest.raises(AssertionError):  # never on the wire
        check_undetected_corruption(fake, wire, request, p.AnalogReadReply(2, 998))
    fake.corrupted_replies = 0
    with pytest.raises(AssertionError):  # no fault at all
        check_undetected_corruption(fake, wire, request, corrupt)
