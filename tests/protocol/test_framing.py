"""CRC-16 framing (docs/protocol.md 7.7): the check, the decoder, and the session's
negotiation and recovery, driven byte by byte with no I/O."""

from __future__ import annotations

import binascii
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arduinoio_async import protocol as p
from arduinoio_async.protocol.session import Session, SessionState

from .strategies import board_frames, requests

CRC = p.Framing.CRC16
ALL_FEATURES = p.Feature(sum(int(f) for f in p.Feature))


def crc_bytes(frame: p.Frame) -> bytes:
    return p.crc_framed(frame.encode())


def test_the_check_is_crc16_ccitt_false() -> None:
    # the catalogue's check value of CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF)
    assert p.crc16(b"123456789") == 0x29B1
    # Table I in CRC framing, as docs/protocol.md 7.7 spells it
    assert crc_bytes(p.ReadId()) == bytes.fromhex("01020e7c")


@given(board_frames)
def test_every_board_frame_round_trips_in_crc_framing(frame: p.Frame) -> None:
    raw = crc_bytes(frame)
    assert len(raw) == len(frame.encode()) + 1
    assert binascii.crc_hqx(raw, 0xFFFF) == 0
    assert p.Decoder.from_board(framing=CRC).feed(raw) == [frame]


@given(requests)
def test_every_request_round_trips_in_crc_framing(request: p.Request[Any]) -> None:
    assert p.Decoder.from_host(framing=CRC).feed(p.crc_framed(request.encode())) == [request]


@settings(max_examples=300)
@given(board_frames, st.data())
def test_every_burst_of_up_to_16_bits_is_detected(frame: p.Frame, data: st.DataObject) -> None:
    """CRC-16 detects every burst no longer than 16 bits (and every odd bit count): a
    damaged frame is garbage, never a frame."""
    raw = bytearray(crc_bytes(frame))
    bits = len(raw) * 8
    length = data.draw(st.integers(1, min(16, bits)))
    start = data.draw(st.integers(0, bits - length))
    pattern = 1 | (1 << (length - 1)) | data.draw(st.integers(0, (1 << length) - 1))
    for bit in range(length):
        if pattern >> bit & 1:
            position = start + bit
            raw[position // 8] ^= 0x80 >> (position % 8)
    decoded = p.Decoder.from_board(framing=CRC).feed(bytes(raw))
    assert frame not in decoded
    assert all(isinstance(item, p.Garbage) for item in decoded[:1])


def test_an_xor_frame_is_not_a_crc_frame_and_back() -> None:
    xor = p.ReadIdReply(0x0102).encode()
    assert not any(
        isinstance(i, p.Frame) for i in p.Decoder.from_board(framing=CRC).feed(xor + xor)
    )
    crc = crc_bytes(p.ReadIdReply(0x0102))
    assert p.ReadIdReply(0x0102) not in p.Decoder.from_board().feed(crc)


# ---- the session ------------------------------------------------------------------------


def capabilities(features: p.Feature = ALL_FEATURES) -> p.ReadCapabilitiesReply:
    return p.ReadCapabilitiesReply(1, 0, 1, int(features), p.DEFAULT_BAUD, p.RX_FIFO_SIZE)


def connected(framing: p.Framing = CRC) -> tuple[Session, list[bytes]]:
    """A session that read capabilities announcing CRC-16; returns it and its writes."""
    session = Session(framing=framing)
    wire: list[bytes] = []
    exchange, data = session.send(p.ReadCapabilities())
    wire.append(data)
    out = session.receive_data(capabilities().encode())
    assert exchange.done and exchange.reply == capabilities()
    wire.append(out.outgoing)
    return session, wire


def test_capabilities_with_the_bit_start_a_set_framing_barrier() -> None:
    session, wire = connected()
    assert wire[-1] == p.SetFraming(CRC).encode()  # sent in XOR framing: 01 0B 01 0B
    assert session.framing.current is CRC  # its reply comes CRC-framed
    # nothing goes behind the barrier until its reply is in
    exchange, data = session.send(p.ReadId())
    assert data == b"" and session.queued == 1
    out = session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    assert out.outgoing == crc_bytes(p.ReadId())  # framed again when it went out
    # no identity expected yet: a free value, held until the line stays quiet
    assert session.receive_data(crc_bytes(p.ReadIdReply(7))).hold
    session.release_held()
    assert exchange.reply == p.ReadIdReply(7)
    assert session.stats.framing_switches == 1


def test_a_board_without_the_bit_keeps_the_papers_framing() -> None:
    session = Session(framing=CRC)
    session.send(p.ReadCapabilities())
    out = session.receive_data(capabilities(ALL_FEATURES & ~p.Feature.CRC16).encode())
    assert out.outgoing == b""
    _, data = session.send(p.ReadId())
    assert data == p.ReadId().encode()
    assert session.framing.current is p.Framing.XOR


def test_a_host_that_asks_for_xor_never_switches() -> None:
    session, wire = connected(p.Framing.XOR)
    assert wire[-1] == b""
    assert session.framing.current is p.Framing.XOR


def test_noise_instead_of_the_set_framing_reply_makes_the_probe_decide() -> None:
    session, _ = connected()
    session.receive_data(b"\x55\x13")  # garbage where the CRC-framed reply should be
    assert session.state is SessionState.DRAINING
    probe = session.start_probe()
    assert probe == crc_bytes(p.ReadId())
    # the board never switched (the request was lost): it could not parse a CRC probe
    session.receive_data(p.ErrorReply(0x01, 0x02, p.ErrorCode.BAD_CHECKSUM).encode())
    assert session.framing.current is p.Framing.XOR
    assert session.state is SessionState.DRAINING
    assert session.start_probe() == p.ReadId().encode()
    out = session.receive_data(p.ReadIdReply(7).encode())
    assert session.state is SessionState.READY
    # ... and it negotiates again, as a barrier
    assert out.outgoing == b"" or out.outgoing == p.SetFraming(CRC).encode()
    assert session.admit() in (b"", p.SetFraming(CRC).encode())
    assert session.framing.negotiation is not None


def test_a_board_reset_mid_session_falls_back_and_renegotiates() -> None:
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, data = session.send(p.AnalogRead(1))
    assert data == crc_bytes(p.AnalogRead(1))
    # the board reset: it parses 03 02 01 <crc high> as XOR and reports a bad checksum
    session.receive_data(p.ErrorReply(0x03, 0x02, p.ErrorCode.BAD_CHECKSUM).encode())
    session.expire(exchange)
    assert session.state is SessionState.DRAINING
    session.start_probe()
    session.receive_data(p.ErrorReply(0x01, 0x02, p.ErrorCode.BAD_CHECKSUM).encode())
    assert session.framing.current is p.Framing.XOR
    assert session.start_probe() == p.ReadId().encode()
    session.receive_data(p.ReadIdReply(7).encode())
    assert session.state is SessionState.READY
    assert session.framing.negotiation is not None  # SetFraming(CRC16) again


def test_a_board_left_in_crc_framing_is_found_by_the_probe() -> None:
    session = Session()  # knows nothing yet: XOR, capabilities unread
    exchange, _ = session.send(p.ReadId())
    session.expire(exchange)
    session.start_probe()
    # a board in CRC framing answers the XOR probe 01 02 03 with a CRC-framed error
    session.receive_data(p.crc_framed(p.ErrorReply(1, 2, p.ErrorCode.BAD_CHECKSUM).encode()))
    assert session.framing.current is CRC
    assert session.start_probe() == crc_bytes(p.ReadId())
    session.receive_data(crc_bytes(p.ReadIdReply(7)))
    assert session.state is SessionState.READY


@settings(max_examples=200)
@given(st.binary(min_size=1, max_size=12))
def test_noise_during_a_probe_never_switches_the_framing(noise: bytes) -> None:
    """What switches the framing must answer the probe (its ID, or a framing error
    naming 01 02) in the other framing's check: noise bytes do not."""
    session = Session()
    exchange, _ = session.send(p.ReadId())
    session.expire(exchange)
    session.start_probe()
    session.receive_data(noise)
    assert session.framing.current is p.Framing.XOR


@pytest.mark.parametrize("framing", [p.Framing.XOR, CRC])
def test_set_framing_cannot_be_a_transaction_item(framing: p.Framing) -> None:
    with pytest.raises(ValueError, match="SetFraming cannot be part of a transaction"):
        p.pack_items([p.SetFraming(framing)])


def test_a_lone_crc_frame_followed_by_a_partial_candidate_waits_for_it() -> None:
    """An inserted byte pushes a reply's last CRC byte out: the candidate one byte
    short passes 1 time in 65,536 and the displaced byte is left over.  A frame with
    bytes left after it is held until they resolve; garbage then fails it."""
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, _ = session.send(p.AnalogRead(1))
    reply = crc_bytes(p.AnalogReadReply(1, 500))
    session.receive_data(reply + b"\x81")  # 0x81 may start an error reply: it waits
    assert not exchange.done
    out = session.receive_data(b"\x00\x00\x00\x00")  # ...and turns out garbage
    assert not exchange.done  # not trusted: a marker tells where the stream is
    assert out.outgoing == crc_bytes(p.ReadCapabilities())
    assert session.receive_data(crc_bytes(capabilities())).hold  # the marker's reply too
    out = session.release_held()
    assert session.stats.retries == 1 and out.outgoing == crc_bytes(p.AnalogRead(1))
    assert session.receive_data(reply).hold  # ends the read: waits one quiet byte time
    session.release_held()
    assert exchange.reply == p.AnalogReadReply(1, 500)
    # a frame followed by a whole valid frame (an event) is trusted
    exchange, _ = session.send(p.AnalogRead(2))
    session.receive_data(crc_bytes(p.AnalogReadReply(2, 7)) + crc_bytes(p.FailsafeTripped())[:2])
    assert not exchange.done
    session.receive_data(crc_bytes(p.FailsafeTripped())[2:])
    assert exchange.reply == p.AnalogReadReply(2, 7)


def test_xor_framed_framing_errors_in_crc_framing_resync_at_once() -> None:
    """After a reset the board answers CRC-framed requests with XOR-framed BAD_CHECKSUM:
    the session resyncs at once instead of waiting for a marker the board cannot parse."""
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    session.send(p.AnalogRead(1))
    out = session.receive_data(p.ErrorReply(0x03, 0x02, p.ErrorCode.BAD_CHECKSUM).encode())
    assert out.lost is not None and "XOR framing" in out.lost
    assert session.state is SessionState.DRAINING


def test_a_damaged_crc_id_reply_that_passes_as_xor_does_not_switch_the_framing() -> None:
    """The soak's one false switch: 0x30 inserted after `01 02 00 33` makes the first
    five bytes a valid XOR-framed ID reply.  Only a framing error about the probe in
    the other framing switches; a reply there is not evidence."""
    session, _ = connected()
    session.receive_data(crc_bytes(p.SetFramingReply(CRC)))
    exchange, _ = session.send(p.ReadId())
    session.expire(exchange)
    session.start_probe()
    damaged = bytes.fromhex("0102003330") + crc_bytes(p.ReadIdReply(0x33))[4:]
    assert p.ReadIdReply(0x33) in p.Decoder.from_board().feed(damaged)  # passes as XOR
    session.receive_data(damaged)
    assert session.framing.current is CRC
