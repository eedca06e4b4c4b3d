"""Transactions: several requests in one frame, run back to back on the board.

``async with board.transaction() as tx:`` collects requests; leaving the block sends them
in one TRANSACTION frame (docs/protocol.md 7.5) and the board answers with every result
in one frame.  Each :meth:`Transaction.add` returns an :class:`Item` typed by its
request's reply, whose :meth:`Item.result` is the reply or raises that item's own
:class:`~arduinoio_async.errors.BoardError`: a refused item does not stop the others.

    async with board.transaction() as tx:
        tx.add(p.GpioWrite(D2, True))
        d3 = tx.add(p.GpioRead(D3))
    print(d3.result().level)

Items are raw protocol requests: a configuration sent this way is not recorded for the
replay after a reconnect, as the handles' own configuration is.

Each transaction of a board gets the next ``seq`` number (mod 256), which its reply
echoes; with at most 64 requests in flight on a link, two transactions in flight never
share one, so the session can place a transaction's reply after line noise as surely as a
single reply's.  The session also checks each item's result against its item and a ReadId
item against the board's ID: a reply that fails is line noise.  A transaction whose reply
was lost is sent again when all its items may be (docs/protocol.md, "Idempotency and
retries"); otherwise it fails with a :class:`~arduinoio_async.errors.LinkError`.
"""

from __future__ import annotations

import itertools
import weakref
from types import TracebackType
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from .. import protocol as p
from ..errors import BoardError, ReplyMismatchError, ValueRangeError, describe_request
from ..protocol._exchange import board_error

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["Item", "Transaction"]

R = TypeVar("R", bound=p.Reply)

#: Each board's transaction numbers (its ``seq`` counter), dropped with the board.
_SEQ: weakref.WeakKeyDictionary[BoardCore, itertools.count[int]] = weakref.WeakKeyDictionary()


def _next_seq(board: BoardCore) -> int:
    counter = _SEQ.get(board)
    if counter is None:
        counter = _SEQ[board] = itertools.count()
    return next(counter) & 0xFF


class Item(Generic[R]):
    """One request of a transaction and, once it ran, its reply or its refusal."""

    __slots__ = ("_error", "_reply", "request")

    def __init__(self, request: p.Request[R]) -> None:
        self.request = request
        self._reply: R | None = None
        self._error: BoardError | None = None

    def __repr__(self) -> str:
        state = self._error or self._reply or "not run"
        return f"<Item {describe_request(self.request)}: {state}>"

    @property
    def done(self) -> bool:
        """Whether the item has its outcome (a reply or an error): the transaction ran."""
        return self._reply is not None or self._error is not None

    @property
    def error(self) -> BoardError | None:
        """The board's refusal of this item, or None."""
        return self._error

    def result(self) -> R:
        """The item's reply; raises the board's refusal of this item."""
        if self._error is not None:
            raise self._error
        if self._reply is None:
            raise RuntimeError("the transaction has not run yet")
        return self._reply


class Transaction:
    """Requests collected for one TRANSACTION frame (see the module docstring)."""

    def __init__(self, board: BoardCore) -> None:
        self.board = board
        self._items: list[Item[Any]] = []
        self._ran = False

    def add(self, request: p.Request[R]) -> Item[R]:
        """Queue ``request``; checked at once against what one transaction can hold."""
        if self._ran:
            raise RuntimeError("this transaction has already run")
        item = Item(request)
        try:
            p.pack_items([*(i.request for i in self._items), request])
        except ValueError as exc:
            raise ValueRangeError("transaction", request, str(exc)) from None
        self._items.append(item)
        return item

    def __len__(self) -> int:
        return len(self._items)

    async def run(self) -> None:
        """Send the items in one frame; every item gets its reply or its refusal."""
        if self._ran:
            raise RuntimeError("this transaction has already run")
        self._ran = True
        requests = [item.request for item in self._items]
        request = p.Transaction(_next_seq(self.board), p.pack_items(requests))
        reply = await self.board.request(request)
        try:  # the session delivered it because it answers every item: this cannot fail
            results = p.unpack_results(requests, reply.results)
        except ValueError as exc:
            raise ReplyMismatchError(f"transaction reply does not answer its items: {exc}") from exc
        for item, result in zip(self._items, results, strict=True):
            if isinstance(result, p.ErrorReply):
                item._error = board_error(result, item.request)
            else:
                item._reply = result

    async def __aenter__(self) -> Transaction:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None and self._items:
            await self.run()
