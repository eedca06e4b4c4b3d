"""Encode/decode of every frame, the paper's tables, chunking and garbage resistance."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from arduinoio_async import protocol as p
from arduinoio_async.errors import FieldRangeError

from .strategies import board_frames, message, requests


def frames_of(decoded: list[p.Decoded]) -> list[p.Frame]:
    return [item for item in decoded if not isinstance(item, p.Garbage)]


@pytest.mark.parametrize("cls", list(p.REQUEST_TYPES.values()), ids=lambda c: c.__name__)
@settings(max_examples=30)
@given(data=st.data())
def test_every_request_round_trips(cls: type[p.Frame], data: st.DataObject) -> None:
    request = data.draw(message(cls))
    assert p.Decoder.from_host().feed(p.encode(request)) == [request]


@pytest.mark.parametrize(
    "cls",
    [*p.REPLY_TYPES.values(), *p.EVENT_TYPES.values()],
    ids=lambda c: c.__name__,
)
@settings(max_examples=30)
@given(data=st.data())
def test_every_reply_and_event_round_trips(cls: type[p.Frame], data: st.DataObject) -> None:
    reply = data.draw(message(cls))
    assert p.Decoder.from_board().feed(reply.encode()) == [reply]


@given(board_frames)
def test_checksum_makes_the_xor_of_every_frame_zero(frame: p.Frame) -> None:
    assert p.checksum(frame.encode()) == 0


def test_paper_table_i_is_the_id_request() -> None:
    assert p.encode(p.ReadId()) == bytes([0x01, 0x02, 0x03])


def test_paper_table_ii_decodes_to_the_board_id() -> None:
    ct, dt, high, low = 0x01, 0x02, 0xAB, 0xCD
    table_ii = bytes([ct, dt, high, low, ct ^ dt ^ high ^ low])
    assert p.Decoder.from_board().feed(table_ii) == [p.ReadIdReply(board_id=0xABCD)]
    assert p.ReadIdReply(board_id=0xABCD).encode() == table_ii


def test_error_reply_layout_sets_the_high_bit_of_the_class_tag() -> None:
    error = p.ErrorReply(class_tag=0x02, descriptor=0x03, code=p.ErrorCode.PIN_NOT_CONFIGURED)
    assert error.encode() == bytes([0x82, 0x03, 0x07, 0x82 ^ 0x03 ^ 0x07])
    assert error.answers(p.GpioWrite(pin=2, value=True))
    assert not error.answers(p.GpioRead(pin=2))


def test_reply_matching_checks_the_echoed_fields() -> None:
    request = p.GpioWrite(pin=4, value=True)
    assert request.matches(p.GpioWriteReply(pin=4, value=True))
    assert not request.matches(p.GpioWriteReply(pin=5, value=True))
    assert not request.matches(p.GpioWriteReply(pin=4, value=False))
    assert not request.matches(p.GpioReadReply(pin=4, state=p.GpioState.HIGH))
    read = p.I2CRead(address=0x50, register=3, length=2)
    assert read.matches(p.I2CReadReply(address=0x50, register=3, data=b"ab"))
    assert not read.matches(p.I2CReadReply(address=0x50, register=3, data=b"a"))


def test_values_that_do_not_fit_raise_the_protocols_own_error() -> None:
    with pytest.raises(FieldRangeError):
        p.encode(p.GpioWrite(pin=256, value=True))
    with pytest.raises(FieldRangeError):
        p.encode(p.I2CWrite(address=0x50, register=0, data=bytes(33)))


@given(st.lists(board_frames, max_size=20), st.data())
def test_chunked_stream_decodes_like_the_whole(frames: list[p.Frame], data: st.DataObject) -> None:
    stream = b"".join(f.encode() for f in frames)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=12)))
    decoder = p.Decoder.from_board()
    out: list[p.Decoded] = []
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        out += decoder.feed(stream[start:end])
    assert out == frames
    assert decoder.buffered == 0


def _merged(decoded: list[p.Decoded]) -> list[p.Frame | bytes]:
    """Frames in order, with adjacent garbage runs joined (their split depends on chunking)."""
    out: list[p.Frame | bytes] = []
    for item in decoded:
        if isinstance(item, p.Garbage):
            if out and isinstance(out[-1], bytes):
                out[-1] += item.data
            else:
                out.append(item.data)
        else:
            out.append(item)
    return out


@given(board_frames, st.data())
def test_a_chunk_of_one_frame_decodes_as_its_bytes_one_by_one(
    frame: p.Frame, data: st.DataObject
) -> None:
    """The decoder's fast path (a chunk that is exactly one frame) against the general path
    (the same bytes one at a time), for the frame intact or with one byte changed."""
    raw = bytearray(frame.encode())
    if data.draw(st.booleans()):
        raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    whole = p.Decoder.from_board()
    single = p.Decoder.from_board()
    by_bytes: list[p.Decoded] = []
    for byte in raw:
        by_bytes += single.feed(bytes((byte,)))
    assert _merged(whole.feed(bytes(raw))) == _merged(by_bytes)
    assert whole.buffered == single.buffered


@given(st.lists(requests, max_size=20), st.data())
def test_requests_split_at_every_byte_decode_intact(
    frames: list[p.Frame], data: st.DataObject
) -> None:
    stream = b"".join(f.encode() for f in frames)
    decoder = p.Decoder.from_host()
    out: list[p.Decoded] = []
    for byte in stream:
        out += decoder.feed(bytes([byte]))
    assert out == frames


#: Bytes that cannot start any board frame: garbage made of them never hides a frame.
_NON_STARTERS = [b for b in range(0x80) if b not in {int(t) for t in p.ClassTag} and b != p.FILLER]
#: Arbitrary junk without filler bytes (filler is dropped, not counted as garbage).
_JUNK = st.binary(max_size=12).map(lambda b: b.replace(bytes([p.FILLER]), b"\xff"))


@given(
    st.lists(
        st.tuples(
            st.binary(max_size=8).map(
                lambda b: bytes(_NON_STARTERS[x % len(_NON_STARTERS)] for x in b)
            ),
            board_frames,
        ),
        max_size=15,
    )
)
def test_frames_between_non_frame_garbage_all_come_out(
    pieces: list[tuple[bytes, p.Frame]],
) -> None:
    stream = b"".join(junk + frame.encode() for junk, frame in pieces)
    out = p.Decoder.from_board().feed(stream)
    assert frames_of(out) == [frame for _, frame in pieces]
    garbage = b"".join(g.data for g in out if isinstance(g, p.Garbage))
    assert garbage == b"".join(junk for junk, _ in pieces)


@settings(max_examples=400)
@given(st.lists(st.tuples(st.binary(max_size=12), board_frames), max_size=15), st.data())
def test_arbitrary_garbage_never_raises_and_never_yields_a_bad_frame(
    pieces: list[tuple[bytes, p.Frame]], data: st.DataObject
) -> None:
    stream = b"".join(junk + frame.encode() for junk, frame in pieces)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=8)))
    decoder = p.Decoder.from_board(drop_filler=False)  # every byte counted below
    out: list[p.Decoded] = []
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        out += decoder.feed(stream[start:end])
    # A half candidate at the end (say 0x40 0x01, a stream sample's start) holds back the
    # bytes after it until it can be judged; bytes that start no frame let it be judged.
    flush = bytes(64)
    out += decoder.feed(flush)
    decoded = frames_of(out)
    for frame in decoded:
        assert p.checksum(frame.encode()) == 0
    originals = [frame for _, frame in pieces]
    spurious = [f for f in decoded if f not in originals]
    missing = [f for f in originals if f not in decoded]
    # An 8-bit checksum lets a garbage run form a valid-looking frame with probability
    # 1/256; only such a spurious frame can swallow a real one.
    if missing:
        assert spurious
    # Every byte is accounted for: frames plus garbage plus what is still buffered.
    total = sum(len(f.encode()) for f in decoded)
    total += sum(len(g.data) for g in out if isinstance(g, p.Garbage))
    assert total + decoder.buffered == len(stream) + len(flush)


@given(
    st.lists(st.tuples(st.integers(0, 120), _JUNK.map(lambda b: b[:4]), board_frames), max_size=12),
    st.data(),
)
def test_filler_between_frames_is_dropped_and_never_becomes_a_frame_or_garbage(
    pieces: list[tuple[int, bytes, p.Frame]], data: st.DataObject
) -> None:
    """Low-latency mode: runs of FILLER between frames vanish; garbage stays garbage."""
    stream = b"".join(
        frame.encode() + bytes([p.FILLER]) * filler + junk for filler, junk, frame in pieces
    )
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=8)))
    decoder = p.Decoder.from_board()
    out: list[p.Decoded] = []
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        out += decoder.feed(stream[start:end])
    out += decoder.feed(bytes([0x7F]) * 64)  # judge a held-back candidate
    originals = [frame for _, _, frame in pieces]
    decoded = frames_of(out)
    spurious = [f for f in decoded if f not in originals]
    assert all(p.checksum(f.encode()) == 0 for f in decoded)
    if not any(junk for _, junk, _ in pieces):
        assert decoded == originals and not spurious
        assert all(set(g.data) <= {0x7F} for g in out if isinstance(g, p.Garbage))
    else:  # garbage costs a real frame only by forming a spurious one
        assert all(f in decoded for f in originals) or spurious


def test_a_filler_run_after_a_reply_costs_nothing_and_a_host_decoder_keeps_it() -> None:
    reply = p.ReadIdReply(0x0102).encode()
    padded = reply + bytes([p.FILLER]) * (p.LOW_LATENCY_PAD - len(reply))
    assert p.Decoder.from_board().feed(padded) == [p.ReadIdReply(0x0102)]
    # split anywhere, filler first: nothing but the reply comes out
    decoder = p.Decoder.from_board()
    out = decoder.feed(padded[:3]) + decoder.feed(padded[3:60] + padded[:2])
    out += decoder.feed(padded[2:60])
    assert out == [p.ReadIdReply(0x0102)] * 2 and decoder.buffered == 0
    # a request decoder (boards and test peers) still calls 0x00 garbage
    assert p.Decoder.from_host().feed(bytes(3)) == [p.Garbage(bytes(3))]


def test_zeros_after_garbage_are_garbage_until_a_frame_or_a_reset() -> None:
    """A damaged frame's bytes are all reported (0x00 inside it too), so a caller sees
    every byte of the damage; filler is recognised again after the next frame."""
    reply = p.ReadIdReply(0x0100).encode()  # 01 02 01 00 CS
    decoder = p.Decoder.from_board()
    damaged = b"\x7e" + reply[2:]  # lost its first two bytes, a stray byte before
    out = decoder.feed(damaged + bytes(3))
    assert out == [p.Garbage(damaged + bytes(3))]
    assert decoder.feed(reply + bytes(5)) == [p.ReadIdReply(0x0100)]
    decoder.feed(b"\x7e")
    decoder.reset()
    assert decoder.feed(bytes(4) + reply) == [p.ReadIdReply(0x0100)]


@given(st.binary(max_size=400))
def test_random_bytes_never_raise(data: bytes) -> None:
    for decoder in (p.Decoder.from_board(), p.Decoder.from_host()):
        for item in decoder.feed(data):
            if not isinstance(item, p.Garbage):
                assert p.checksum(item.encode()) == 0


def test_reset_drops_a_partial_frame() -> None:
    decoder = p.Decoder.from_board()
    assert decoder.feed(bytes([0x01, 0x02, 0x00])) == []
    assert decoder.reset() == bytes([0x01, 0x02, 0x00])
    assert decoder.feed(p.ReadIdReply(board_id=7).encode()) == [p.ReadIdReply(board_id=7)]


def test_a_stream_sample_with_a_payload_that_contradicts_its_mask_is_garbage() -> None:
    good = p.StreamSample(
        analog_mask=0b11, flags=p.StreamFlags.NONE, sequence=1, timestamp_us=5, payload=bytes(4)
    )
    raw = bytearray(good.encode())
    raw[2] = 0b111  # three channels announced, two carried
    raw[-1] = p.checksum(raw[:-1])
    out = p.Decoder.from_board().feed(bytes(raw))
    assert not frames_of(out)


@pytest.mark.parametrize("state", [0x00, 0x01, 0x02, 0x05, 0x06, 0x07])
def test_a_gpio_change_that_is_not_one_edge_is_garbage(state: int) -> None:
    good = p.GpioChange(pin=3, state=p.GpioState.FELL, sequence=9, timestamp_us=1234)
    raw = bytearray(good.encode())
    raw[3] = state  # only HIGH|ROSE (0x03) and FELL (0x04) describe one change
    raw[-1] = p.checksum(raw[:-1])
    out = p.Decoder.from_board().feed(bytes(raw))
    assert not frames_of(out)


def test_stream_admission_rule_matches_the_documented_limits() -> None:
    four = 0b1111
    assert p.stream_min_period_us(four, p.StreamFlags.NONE, 115200) == 2350
    assert p.stream_min_period_us(four, p.StreamFlags.NONE, 1_000_000) == 300
    assert not p.stream_fits_link(20, 2300, 115200)
