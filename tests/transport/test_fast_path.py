"""The host's common case, made cheap, must give the same outcomes as the general path.

Covers the decoder's whole-frame memo, the session's ``receive_reply`` and its checks of
what a board can send, and the transport's deadline alarm (one per link, no loop timer).
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardTimeoutError, LinkResyncError
from arduinoio_async.protocol.session import TEMPERATURE_RAW_RANGE, Session, SessionState
from arduinoio_async.testing import FakeBoard, Faults
from arduinoio_async.transport import Transport


def test_whole_frame_gives_what_feed_gives_and_the_memo_stays_bounded() -> None:
    decoder = p.Decoder.from_board()
    reference = p.Decoder.from_board()
    for value in range(2 * p.Decoder.MEMO_SIZE + 3):
        data = p.AnalogReadReply(value % 6, value % 1024).encode()
        assert decoder.whole_frame(data) == reference.feed(data)[0]
    assert len(decoder._memo) <= p.Decoder.MEMO_SIZE
    again = p.AnalogReadReply(1, 1).encode()
    assert decoder.whole_frame(again) is decoder.whole_frame(again)  # remembered


@pytest.mark.parametrize(
    "data",
    [
        p.ReadIdReply(7).encode()[:-1],  # a partial frame
        p.ReadIdReply(7).encode() + b"\x01",  # a frame and more
        bytes([0x01, 0x02, 0x00, 0x07, 0x00]),  # a bad checksum
        p.AnalogReadReply(1, 1).encode()[:2] + b"\xff\xff" + b"\x00",  # a value out of range
        p.ErrorReply(1, 2, p.ErrorCode(3)).encode(),  # error replies take the general path
    ],
)
def test_whole_frame_takes_only_one_whole_valid_frame_and_consumes_nothing(data: bytes) -> None:
    decoder = p.Decoder.from_board()
    assert decoder.whole_frame(data) is None
    assert decoder.buffered == 0
    assert decoder.feed(data) == p.Decoder.from_board().feed(data)


def test_whole_frame_waits_behind_buffered_bytes() -> None:
    decoder = p.Decoder.from_board()
    frame = p.ReadIdReply(7).encode()
    assert decoder.feed(frame[:2]) == []
    assert decoder.whole_frame(frame) is None  # these bytes continue the buffered ones


def test_receive_reply_completes_the_common_case_only() -> None:
    session = Session(expected_id=7)
    exchange, _ = session.send(p.ReadId())
    assert session.receive_reply(p.AnalogReadReply(1, 1).encode()) is None  # not its reply
    assert session.receive_reply(p.ReadIdReply(7).encode()) is exchange
    assert exchange.done and exchange.reply == p.ReadIdReply(7)
    assert session.in_flight == 0 and session.stats.replies == 1
    first, _ = session.send(p.ReadId())
    second, _ = session.send(p.ReadId())
    assert session.receive_reply(p.ReadIdReply(7).encode()) is None  # two in flight
    assert not first.done
    out = session.receive_data(p.ReadIdReply(7).encode() * 2)
    assert out.done == [first, second]


def test_a_reply_naming_another_board_is_noise_and_the_read_is_asked_again() -> None:
    session = Session(expected_id=0x0033)
    exchange, _ = session.send(p.ReadId())
    assert session.receive_reply(p.ReadIdReply(0x0133).encode()) is None
    out = session.receive_data(p.ReadIdReply(0x0133).encode())  # passed the checksum, say
    assert out.done == [] and not exchange.done
    assert session.state == SessionState.READY
    # The marker behind it comes back alone: the ID reply was lost, so ReadId is re-sent.
    marker = p.ReadCapabilitiesReply(p.PROTOCOL_VERSION, 1, 0, 0x3FF, 115200, 64)
    out = session.receive_data(marker.encode())
    assert p.ReadId().encode() in out.outgoing and not exchange.done
    out = session.receive_data(p.ReadIdReply(0x0033).encode())
    assert out.done == [exchange] and exchange.reply == p.ReadIdReply(0x0033)


def test_a_temperature_the_sensor_cannot_report_is_never_an_answer() -> None:
    assert 292 in TEMPERATURE_RAW_RANGE  # 25 C at 1.1 V
    assert 0x3FF not in TEMPERATURE_RAW_RANGE and 0 not in TEMPERATURE_RAW_RANGE
    session = Session()
    exchange, _ = session.send(p.ReadTemperature())
    out = session.receive_data(p.ReadTemperatureReply(0x3FF).encode())
    assert out.done == [] and not exchange.done
    session.receive_data(
        p.ReadCapabilitiesReply(p.PROTOCOL_VERSION, 1, 0, 0x3FF, 115200, 64).encode()
    )
    session.receive_data(p.ReadTemperatureReply(292).encode())
    assert exchange.reply == p.ReadTemperatureReply(292)


async def test_a_short_timeout_behind_a_long_one_expires_on_time() -> None:
    """The link's one alarm is armed for the earliest deadline, whatever the order."""
    fake = FakeBoard(board_id=0x0102, faults=Faults(lose_reply=1.0))
    async with fake, Transport(fake.host_stream, timeout=30.0, quiet_time=0.005) as link:
        failures: list[BaseException] = []

        async def long_wait() -> None:
            try:
                await link.request(p.ReadId())
            except LinkResyncError as exc:  # lost with the link's sync, or retried out
                failures.append(exc)
            except BoardTimeoutError as exc:
                failures.append(exc)

        with anyio.fail_after(5):
            async with anyio.create_task_group() as tg:
                tg.start_soon(long_wait)
                await anyio.wait_all_tasks_blocked()
                with pytest.raises(BoardTimeoutError):
                    await link.request(p.AnalogRead(1), timeout=0.05)
                tg.cancel_scope.cancel()


def test_feed_shares_the_memo_and_keeps_it_to_valid_frames() -> None:
    """Pipelined replies read in one chunk are remembered too; garbage and error replies
    never are, and a remembered frame gives what decoding it afresh gives."""
    decoder = p.Decoder.from_board()
    replies = [p.GpioWriteReply(2 + i % 4, bool(i % 2)) for i in range(8)]
    chunk = b"".join(r.encode() for r in replies)
    first = decoder.feed(chunk)
    assert first == replies
    again = decoder.feed(chunk)
    assert again == replies and all(a is b for a, b in zip(again, first, strict=True))
    bad = bytearray(replies[0].encode())
    bad[-1] ^= 0xFF
    error = p.ErrorReply(1, 2, p.ErrorCode(3)).encode()
    decoder.feed(bytes(bad) + error)
    assert bytes(bad) not in decoder._memo and error not in decoder._memo
    assert set(decoder._memo) == {r.encode() for r in replies}
