"""Stepping a request's coroutine from loop callbacks, without a task (asyncio only)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Coroutine
from typing import Any

from .. import protocol as p

__all__ = ["Resumer"]


class Resumer:
    """Runs ``Transport.request(...)`` from loop callbacks, without a task (asyncio only).

    On asyncio the request suspends only on the asyncio future its reply resolves (or,
    refused at once, on a bare checkpoint): so the coroutine is stepped here -- at once,
    which puts the request on the wire in the caller's callback, and again from the
    future's done-callback, which hands the outcome to ``done`` -- as a task would step it,
    minus the task's creation and its extra scheduling.  Nothing here can be cancelled:
    the transport's own deadline ends every request.
    """

    __slots__ = ("_coro", "_done")

    def __init__(
        self,
        coro: Coroutine[Any, Any, p.Reply],
        done: Callable[[p.Reply | None, BaseException | None], None],
    ) -> None:
        self._coro = coro
        self._done = done
        self._step()

    def _step(self, _: object = None) -> None:
        try:
            waiting = self._coro.send(None)
        except StopIteration as finished:
            self._done(finished.value, None)
        except (Exception, asyncio.CancelledError) as exc:
            self._done(None, exc)
        else:
            if waiting is None:  # a bare checkpoint
                asyncio.get_running_loop().call_soon(self._step)
            elif isinstance(waiting, asyncio.Future):
                waiting._asyncio_future_blocking = False
                waiting.add_done_callback(self._step)
            else:  # not an asyncio awaitable: the transport changed; fail loudly
                self._coro.close()
                self._done(None, RuntimeError(f"request suspended on {waiting!r}"))
