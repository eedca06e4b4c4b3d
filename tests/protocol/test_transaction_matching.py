"""A TRANSACTION reply is matched as strictly as a single reply.

The sans-IO session decides which request a reply answers.  For a transaction that means
every item's echo, the board's ID in a ReadId item, and the transaction's own tag: a
reply that fails any of them is line noise (the transaction is retried when that is safe,
else fails with a LinkError), never a wrong value handed to the caller.
"""

from __future__ import annotations

from typing import Any

from arduinoio_async import protocol as p
from arduinoio_async.errors import LinkError, LinkResyncError
from arduinoio_async.protocol.session import Session, SessionState

BOARD_ID = 0x0077


def tx(seq: int, *requests: p.Request[Any]) -> p.Transaction:
    return p.Transaction(seq, p.pack_items(requests))


def reply(seq: int, *frames: p.Frame) -> bytes:
    return p.TransactionReply(seq, b"".join(f.encode()[:-1] for f in frames)).encode()


def item_answer(item: p.Request[Any]) -> p.Reply:
    if isinstance(item, p.ReadId):
        return p.ReadIdReply(BOARD_ID)
    if isinstance(item, p.GpioWrite):
        return p.GpioWriteReply(item.pin, item.value)
    assert isinstance(item, p.AnalogRead)
    return p.AnalogReadReply(item.channel, 100 + item.channel)


def converse(session: Session, sent: bytes) -> None:
    while sent:
        sent = session.receive_data(answer(sent)).outgoing


def answer(sent: bytes) -> bytes:
    """A model board's replies to what the session sent (marker and retries)."""
    replies = b""
    for frame in p.Decoder.from_host().feed(sent):
        if isinstance(frame, p.ReadCapabilities):
            replies += p.ReadCapabilitiesReply(
                p.PROTOCOL_VERSION, 0, 1, 0x3FF, 1_000_000, 64
            ).encode()
        elif isinstance(frame, p.Transaction):
            results = [item_answer(item) for item in p.item_requests(frame.items)]
            replies += reply(frame.seq, *results)
        else:
            raise AssertionError(frame)
    return replies


def test_an_item_reply_that_does_not_answer_its_item_is_noise() -> None:
    """GpioWriteReply(pin=12, value=False) for GpioWrite(D12, True): never delivered."""
    session = Session(expected_id=BOARD_ID)
    exchange, _ = session.send(tx(1, p.GpioWrite(12, True)))
    session.receive_data(reply(1, p.GpioWriteReply(12, False)))
    assert exchange.reply is None
    # as for a single request whose reply does not echo it (ReplyMismatchError)
    assert isinstance(exchange.error, LinkError)


def test_another_transactions_reply_is_not_taken() -> None:
    """The head's reply is lost whole; the next transaction's reply (same tags, same item
    shape) must not be taken for it."""
    session = Session(expected_id=BOARD_ID)
    first, _ = session.send(tx(1, p.GpioWrite(12, True)))
    second, _ = session.send(tx(2, p.GpioWrite(12, False)))
    third, _ = session.send(tx(3, p.ReadId()))
    session.receive_data(reply(2, p.GpioWriteReply(12, False)) + reply(3, p.ReadIdReply(BOARD_ID)))
    assert first.reply is None and isinstance(first.error, LinkError)
    assert third.reply is not None
    assert second.reply == p.TransactionReply(2, p.GpioWriteReply(12, False).encode()[:-1])


def test_a_read_id_item_with_another_id_is_noise() -> None:
    """As for a plain read_id: 0x0200 is not this board's ID, so it cannot be its reply."""
    session = Session(expected_id=BOARD_ID)
    exchange, _ = session.send(tx(1, p.ReadId()))
    out = session.receive_data(reply(1, p.ReadIdReply(0x0200)))
    assert exchange.reply is None
    # The board answers what the session sent since: the marker, then the retry.
    converse(session, out.outgoing)
    assert exchange.reply is not None
    assert p.unpack_results([p.ReadId()], exchange.reply.results) == (p.ReadIdReply(BOARD_ID),)


def test_same_shape_transactions_are_told_apart_after_noise() -> None:
    """Three transactions with the same items: the first reply is damaged.  The tag each
    reply echoes places the second reply; only the first transaction is affected, and it is
    asked again (its only item reads)."""
    session = Session(expected_id=BOARD_ID)
    exchanges = [session.send(tx(seq, p.AnalogRead(2)))[0] for seq in (1, 2, 3)]
    replies = [reply(seq, p.AnalogReadReply(2, 100 + seq)) for seq in (1, 2, 3)]
    damaged = bytearray(replies[0])
    damaged[4] ^= 0x40
    out = session.receive_data(bytes(damaged) + replies[1] + replies[2])
    assert session.state is SessionState.READY
    for seq in (2, 3):
        want = p.TransactionReply(seq, p.AnalogReadReply(2, 100 + seq).encode()[:-1])
        assert exchanges[seq - 1].reply == want
    assert not exchanges[0].done
    assert exchanges[0].frame in out.outgoing  # retried: reading is safe to repeat


def test_a_transaction_with_a_side_effect_on_a_pin_written_later_is_not_retried() -> None:
    session = Session(expected_id=BOARD_ID)
    first, _ = session.send(tx(1, p.GpioWrite(12, True), p.AnalogRead(2)))
    second, _ = session.send(tx(2, p.GpioWrite(12, False)))
    damaged = bytearray(reply(1, p.GpioWriteReply(12, True), p.AnalogReadReply(2, 5)))
    damaged[3] ^= 0x01
    session.receive_data(bytes(damaged) + reply(2, p.GpioWriteReply(12, False)))
    assert isinstance(first.error, LinkResyncError)
    assert second.reply is not None


def test_a_frame_that_could_answer_two_requests_fails_only_those_before_the_next_placed() -> None:
    """Two identical reads behind a long reply that noise destroyed: each GpioRead reply could
    be either read's (the noise fits both), so it counts as noise instead of losing sync.
    The ReadId reply behind them places the stream again: the reads before it fail (GpioRead
    clears edges: not repeated), the I2C read is asked again, the ReadId is answered."""
    session = Session(expected_id=BOARD_ID)
    i2c, _ = session.send(p.I2CRead(0x50, 0, 10))
    reads = [session.send(p.GpioRead(2))[0] for _ in range(2)]
    read_id, _ = session.send(p.ReadId())
    damaged = bytearray(p.I2CReadReply(0x50, 0, bytes(range(10))).encode())
    damaged[7] ^= 0x20
    read_reply = p.GpioReadReply(2, p.GpioState.HIGH).encode()
    session.receive_data(bytes(damaged) + read_reply + read_reply)
    marker = answer(p.ReadCapabilities().encode())  # the session's marker, sent after noise
    out = session.receive_data(p.ReadIdReply(BOARD_ID).encode() + marker)
    assert session.state is SessionState.READY  # before: lost sync, everything in flight failed
    assert session.stats.ambiguous == 2
    assert read_id.reply == p.ReadIdReply(BOARD_ID)
    assert all(isinstance(r.error, LinkResyncError) and r.reply is None for r in reads)
    assert not i2c.done and p.I2CRead(0x50, 0, 10).encode() in out.outgoing
