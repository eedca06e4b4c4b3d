"""TRANSACTION (extension, docs/protocol.md 7.5), run by ``firmware/src/transaction.c``:
several requests in one frame.

The items of a TRANSACTION request are request frames without their checksums, one after
the other; the reply holds each item's reply frame (or error reply) without its
checksum, in the same order.  The board checks the whole list before it runs any item
(known tags, whole frames, no RESET or nested TRANSACTION, every possible reply fits
the reply), so an item list it refuses has changed nothing; then it runs the items back
to back, and an item the board refuses does not stop the ones after it.

A reply proves it answers its transaction as a single reply does: it echoes the
transaction's ``seq`` byte (the host numbers its transactions, so two in flight never
share one) and every item's result echoes its item (:meth:`Transaction.matches`).  The
session checks both before it hands a reply out, so a reply damaged past the 8-bit
checksum, or one that answers another transaction, is line noise, not a wrong value.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from functools import lru_cache
from typing import Annotated, Any

from .._constants import ERROR_FLAG, MAX_BLOB, ClassTag, ErrorCode
from .._layout import U8, Blob, Frame, Layout, checksum
from .._messages import (
    REPLY_TYPES,
    REQUEST_TYPES,
    ErrorReply,
    Reply,
    Request,
    echo,
    reply_frame,
    request_frame,
)
from .i2c import I2CRead
from .misc import Reset, SetFraming

__all__ = [
    "Transaction",
    "TransactionReply",
    "item_requests",
    "pack_items",
    "readable_items",
    "result_size",
    "split_results",
    "unpack_results",
]


@echo
class _Seq:
    """The host's number for a transaction, which its reply repeats: what tells apart two
    transactions in flight with the same items (their tags alone cannot)."""

    seq: Annotated[int, U8]


@reply_frame(ClassTag.MISC, 0x09)
class TransactionReply(_Seq, Reply):
    """Every item's reply frame (or error reply) without its checksum, in item order."""

    results: Annotated[bytes, Blob(MAX_BLOB)]


@request_frame(TransactionReply, extension=True)
class Transaction(_Seq, Request[TransactionReply]):
    """Several requests run back to back on the board, one reply with every result.

    ``items`` holds the request frames without their checksums (docs/protocol.md 7.5);
    build it with :func:`~arduinoio_async.protocol.pack_items`.  ``seq`` is echoed by the
    reply; the host gives each transaction in flight its own.
    """

    items: Annotated[bytes, Blob(MAX_BLOB)]

    def matches(self, reply: Reply) -> bool:
        """The reply echoes ``seq`` and each item's result answers its item."""
        if type(reply) is not TransactionReply or reply.seq != self.seq:
            return False
        try:
            unpack_results(item_requests(self.items), reply.results)
        except ValueError:
            return False
        return True

    def parts(self) -> tuple[Request[Any], ...]:
        """The items: what runs on the board, for the retry rules."""
        try:
            return item_requests(self.items)
        except ValueError:
            return (self,)


#: Requests a transaction cannot carry: RESET restarts the board mid-list, and a
#: transaction inside a transaction would make the reply's size unbounded; SET_FRAMING
#: would change the framing of the reply it is part of.
NOT_IN_TRANSACTIONS: tuple[type[Request[Any]], ...] = (Reset, Transaction, SetFraming)


def result_size(request: Request[Any]) -> int:
    """Bytes the item's result takes in the reply (its reply frame without checksum).

    An error reply (3 bytes) is never longer than a reply frame (at least CT DT).
    """
    layout = request.REPLY.LAYOUT
    size = layout.base_size - 1
    if isinstance(request, I2CRead):
        size += request.length
    return max(size, ErrorReply.SIZE - 1)


def pack_items(requests: Sequence[Request[Any]]) -> bytes:
    """The ``items`` of a Transaction; ValueError when the board would refuse the list."""
    if not requests:
        raise ValueError("a transaction needs at least one request")
    for request in requests:
        if isinstance(request, NOT_IN_TRANSACTIONS):
            raise ValueError(f"{type(request).__name__} cannot be part of a transaction")
    items = b"".join(request.encode()[:-1] for request in requests)
    if len(items) > MAX_BLOB:
        raise ValueError(f"the requests take {len(items)} bytes; a transaction holds {MAX_BLOB}")
    results = sum(result_size(request) for request in requests)
    if results > MAX_BLOB:
        raise ValueError(f"the replies would take {results} bytes; a transaction holds {MAX_BLOB}")
    return items


def _frame_size(data: bytes, pos: int, layout: Layout) -> int:
    """Bytes the frame of ``layout`` at ``pos`` of ``data`` takes without its checksum
    (items and results hold frames so)."""
    size = layout.base_size - 1
    if layout.length_offset >= 0 and pos + layout.length_offset < len(data):
        size += data[pos + layout.length_offset]
    return size


def _frame_at(data: bytes, pos: int, layout: Layout) -> Frame | None:
    """The frame of ``layout`` at ``pos`` of ``data``; None when ``data`` ends inside
    it, ValueError when a field holds a value its type does not allow."""
    size = _frame_size(data, pos, layout)
    raw = data[pos : pos + size]
    if len(raw) != size:
        return None
    return layout.decode(raw + bytes((checksum(raw),)))


def _error_at(data: bytes, pos: int) -> ErrorReply | None:
    """The error result at ``pos`` (its first byte has the error flag); None when
    ``data`` ends inside it."""
    raw = data[pos : pos + ErrorReply.SIZE - 1]
    if len(raw) != ErrorReply.SIZE - 1:
        return None
    return ErrorReply(raw[0] & ~ERROR_FLAG, raw[1], ErrorCode(raw[2]))


def _read_items(items: bytes) -> Iterator[Request[Any] | None]:
    """Each request packed in ``items`` in turn (None for one whose fields hold values
    their types do not allow); ValueError where the items stop being whole, known request
    frames."""
    pos = 0
    while pos < len(items):
        cls = REQUEST_TYPES.get((items[pos], items[pos + 1])) if pos + 1 < len(items) else None
        if cls is None:
            raise ValueError(f"no request at byte {pos} of the items")
        try:
            request = _frame_at(items, pos, cls.LAYOUT)
        except ValueError:
            request = None
        else:
            if request is None:
                raise ValueError(f"the items end inside a {cls.__name__}")
            assert isinstance(request, Request)
        yield request
        pos += _frame_size(items, pos, cls.LAYOUT)


@lru_cache(maxsize=512)
def item_requests(items: bytes) -> tuple[Request[Any], ...]:
    """The requests packed in ``items`` (the inverse of :func:`pack_items`); ValueError
    when they are not whole, known request frames."""
    out: list[Request[Any]] = []
    for request in _read_items(items):
        if request is None:
            raise ValueError("an item holds a value its type does not allow")
        out.append(request)
    return tuple(out)


def readable_items(items: bytes) -> list[Request[Any]]:
    """The requests of ``items`` that decode, up to where the items stop being whole
    frames: what a transaction may do, for a server that keeps account of it (the board
    refuses an item list that is not whole, and an item it cannot run, by itself)."""
    out: list[Request[Any]] = []
    with contextlib.suppress(ValueError):  # the items stop being whole frames here
        for request in _read_items(items):
            if request is not None:
                out.append(request)
    return out


def split_results(results: bytes) -> tuple[Reply | ErrorReply, ...] | None:
    """The item results read by their own tags, without the requests; None when they are
    not whole reply frames (what a board cannot send: line noise)."""
    out: list[Reply | ErrorReply] = []
    pos = 0
    try:
        while pos < len(results):
            if results[pos] & ERROR_FLAG:
                error = _error_at(results, pos)
                if error is None:
                    return None
                out.append(error)
                pos += ErrorReply.SIZE - 1
                continue
            key = (results[pos], results[pos + 1]) if pos + 1 < len(results) else None
            cls = REPLY_TYPES.get(key) if key is not None else None
            reply = None if cls is None else _frame_at(results, pos, cls.LAYOUT)
            if cls is None or reply is None:
                return None
            assert isinstance(reply, Reply)
            out.append(reply)
            pos += _frame_size(results, pos, cls.LAYOUT)
    except ValueError:
        return None
    return tuple(out)


def unpack_results(
    requests: Sequence[Request[Any]], results: bytes
) -> tuple[Reply | ErrorReply, ...]:
    """Each item's reply or error reply; ValueError when ``results`` does not answer
    ``requests`` item for item (a corrupt frame the 8-bit checksum let through)."""
    out: list[Reply | ErrorReply] = []
    pos = 0
    for request in requests:
        if pos < len(results) and results[pos] & ERROR_FLAG:
            error = _error_at(results, pos)
            if error is None:
                raise ValueError("transaction results end inside an error reply")
            if not error.answers(request):
                raise ValueError(f"item error {error} does not answer {request}")
            out.append(error)
            pos += ErrorReply.SIZE - 1
            continue
        reply = _frame_at(results, pos, request.REPLY.LAYOUT)
        if reply is None:
            raise ValueError(f"transaction results end inside the reply to {request}")
        assert isinstance(reply, Reply)
        if not request.matches(reply):
            raise ValueError(f"item reply {reply} does not answer {request}")
        out.append(reply)
        pos += _frame_size(results, pos, request.REPLY.LAYOUT)
    if pos != len(results):
        raise ValueError(f"{len(results) - pos} bytes left over after the last item's result")
    return tuple(out)
