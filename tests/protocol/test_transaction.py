"""Transactions in the sans-IO core: packing items, reading results item by item."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from arduinoio_async import protocol as p
from arduinoio_async.protocol.commands.transaction import NOT_IN_TRANSACTIONS
from arduinoio_async.testing._fake_transaction import split_items as _split_items

from .strategies import message

#: Requests a transaction may carry (everything but RESET, TRANSACTION and SET_FRAMING).
items = st.one_of(
    *[message(cls) for cls in p.REQUEST_TYPES.values() if cls not in NOT_IN_TRANSACTIONS]
)


@given(st.lists(items, min_size=1, max_size=8))
def test_packed_items_split_back_into_the_same_frames(requests: list[p.Request[p.Reply]]) -> None:
    try:
        packed = p.pack_items(requests)
    except ValueError:
        sizes = sum(len(r.encode()) - 1 for r in requests)
        results = sum(p.result_size(r) for r in requests)
        assert sizes > p.MAX_BLOB or results > p.MAX_BLOB
        return
    frame = p.Transaction(7, packed)
    assert p.Decoder.from_host().feed(frame.encode()) == [frame]
    assert _split_items(packed) == [r.encode()[:-1] for r in requests]


def test_results_are_read_item_by_item_with_errors_in_place() -> None:
    requests = [p.GpioWrite(2, True), p.GpioRead(3), p.CounterRead(2)]
    results = bytes([0x82, 3, p.ErrorCode.PIN_NOT_CONFIGURED, 2, 2, 3, 3, 6, 2, 2, 0, 0, 1, 0])
    assert p.unpack_results(requests, results) == (
        p.ErrorReply(2, 3, p.ErrorCode.PIN_NOT_CONFIGURED),
        p.GpioReadReply(3, p.GpioState.HIGH | p.GpioState.ROSE),
        p.CounterReadReply(2, 256),
    )


@pytest.mark.parametrize(
    "results",
    [
        bytes([2, 3, 2, 1]),  # the read's reply is missing
        bytes([2, 3, 2, 1, 2, 2, 4, 1]),  # the read's reply names another pin
        bytes([2, 3, 2, 1, 2, 2, 3, 1, 0]),  # a byte left over
        bytes([2, 3, 2, 1, 0x83, 2, 9]),  # an error with other tags
        bytes([2, 3, 2, 1, 2, 2, 3, 0xF0]),  # a state with undefined bits
    ],
)
def test_results_that_do_not_answer_the_items_are_refused(results: bytes) -> None:
    with pytest.raises(ValueError):
        p.unpack_results([p.GpioWrite(2, True), p.GpioRead(3)], results)


def test_lists_the_board_would_refuse_are_refused_before_sending() -> None:
    with pytest.raises(ValueError, match="at least one"):
        p.pack_items([])
    with pytest.raises(ValueError, match="Reset"):
        p.pack_items([p.GpioRead(3), p.Reset()])
    with pytest.raises(ValueError, match="replies would take"):
        p.pack_items([p.AnalogReadAll()] * 3)
    six_servos = [p.PwmSet(pin, 1500) for pin in range(2, 8)]
    assert len(p.pack_items(six_servos)) == 30
