"""``Session.relay_failure``: a relaying stream's far end settled one request itself."""

from __future__ import annotations

from arduinoio_async import protocol as p
from arduinoio_async.errors import BoardTimeoutError
from arduinoio_async.protocol.session import Session, SessionState


def test_a_relayed_failure_fails_the_oldest_request_only() -> None:
    session = Session()
    reads = [session.send(p.AnalogRead(channel))[0] for channel in range(3)]
    # The first reply arrives alone: the session holds it until the next chunk shows
    # whether garbage followed it.  The relayed failure is no garbage: it vouches.
    out = session.receive_data(p.AnalogReadReply(0, 5).encode())
    assert out.done == []
    out = session.relay_failure(BoardTimeoutError("timed out on the server"))
    assert out.done == reads[:2]
    assert reads[0].reply == p.AnalogReadReply(0, 5) and reads[0].error is None
    assert isinstance(reads[1].error, BoardTimeoutError) and reads[1].reply is None
    assert session.state is SessionState.READY and out.lost is None
    out = session.receive_data(p.AnalogReadReply(2, 7).encode())
    assert out.done == [reads[2]] and reads[2].reply == p.AnalogReadReply(2, 7)


def test_a_relayed_failure_with_nothing_in_flight_or_out_of_sync_changes_nothing() -> None:
    session = Session()
    assert session.relay_failure(BoardTimeoutError("late")).done == []
    exchange, _ = session.send(p.AnalogRead(1))
    session.expire(exchange)  # the session lost sync itself: the request failed here
    assert session.state is SessionState.DRAINING
    assert session.relay_failure(BoardTimeoutError("late")).done == []
    assert isinstance(exchange.error, BoardTimeoutError)


def test_a_relayed_failure_admits_what_waited_for_the_window() -> None:
    session = Session(window_bytes=6)  # one 4-byte read at a time
    first, sent = session.send(p.AnalogRead(1))
    second, waiting = session.send(p.AnalogRead(2))
    assert sent and not waiting and second.queued
    out = session.relay_failure(BoardTimeoutError("timed out on the server"))
    assert out.done == [first] and out.outgoing == second.frame and not second.queued
