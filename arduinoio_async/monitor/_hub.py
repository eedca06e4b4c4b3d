"""The hub between boards and browsers: fan-out of live data, and controls in.

Every browser tab is a :class:`Subscriber` with a bounded queue.  The hub folds the
activity of each board for :data:`FLUSH_INTERVAL` and sends one message per board per
flush, so the rate a page sees does not depend on the stream's period.  A subscriber
that cannot keep up is disconnected (its page reconnects and starts from a fresh
snapshot) rather than allowed to slow the boards or to grow memory without bound.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import anyio
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from ..errors import ArduinoIOError, UsageError
from ._args import describe_error
from ._panel import BoardPanel

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["FLUSH_INTERVAL", "MonitorHub", "Subscriber"]

logger = logging.getLogger(__name__)

#: Seconds of activity folded into one message per board (about 20 updates a second).
FLUSH_INTERVAL = 0.05
#: Messages a subscriber may have queued before it counts as stuck.
SUBSCRIBER_QUEUE = 256

Message = dict[str, object]


class Subscriber:
    """One browser connection's outgoing queue."""

    def __init__(self) -> None:
        self._send: MemoryObjectSendStream[Message]
        self.messages: MemoryObjectReceiveStream[Message]
        self._send, self.messages = anyio.create_memory_object_stream[Message](SUBSCRIBER_QUEUE)

    def offer(self, message: Message) -> bool:
        """Queue ``message``; False (and the queue closed) if the subscriber is stuck."""
        try:
            self._send.send_nowait(message)
        except anyio.WouldBlock:
            self._send.close()
            return False
        except (anyio.BrokenResourceError, anyio.ClosedResourceError):
            return False
        return True

    def close(self) -> None:
        self._send.close()
        self.messages.close()


class MonitorHub:
    """Boards in, browsers out.  Run :meth:`run` in a task group while serving."""

    def __init__(
        self, boards: Sequence[Board], *, period_ms: float = 20.0, stream: bool = True
    ) -> None:
        self.panels: dict[str, BoardPanel] = {}
        for index, board in enumerate(boards):
            key = f"b{index}"
            self.panels[key] = BoardPanel(
                key, board, period_ms=period_ms, stream=stream, on_change=self._poke
            )
        self._subscribers: set[Subscriber] = set()
        self._activity = anyio.Event()

    def _poke(self) -> None:
        self._activity.set()

    # ---- browsers ---------------------------------------------------------------------------

    def subscribe(self) -> Subscriber:
        """A new subscriber, which gets every board's snapshot first."""
        subscriber = Subscriber()
        for panel in self.panels.values():
            subscriber.offer(panel.snapshot())
        self._subscribers.add(subscriber)
        return subscriber

    def unsubscribe(self, subscriber: Subscriber) -> None:
        self._subscribers.discard(subscriber)
        subscriber.close()

    def broadcast(self, message: Message) -> None:
        for subscriber in list(self._subscribers):
            if not subscriber.offer(message):
                logger.info("monitor: a page fell behind and was disconnected")
                self._subscribers.discard(subscriber)

    # ---- running --------------------------------------------------------------------------

    async def run(self) -> None:
        """Run every board's sources and flush their activity to the pages until cancelled."""
        async with anyio.create_task_group() as tg:
            for panel in self.panels.values():
                tg.start_soon(panel.run)
            tg.start_soon(self._flush_forever)

    async def _flush_forever(self) -> None:
        while True:
            await self._activity.wait()
            self._activity = anyio.Event()
            self.flush()
            await anyio.sleep(FLUSH_INTERVAL)  # what arrives meanwhile goes in the next flush

    def flush(self) -> None:
        for panel in self.panels.values():
            if panel.config_changed:
                panel.config_changed = False
                self.broadcast(panel.snapshot())
            samples = panel.take_samples()
            if samples is not None:
                self.broadcast(samples)

    # ---- controls ---------------------------------------------------------------------------

    async def perform(self, request: Mapping[str, Any]) -> Message:
        """Carry out one control request from a page; the reply names the request's ``id``."""
        reply: Message = {"type": "result", "id": request.get("id"), "op": request.get("op")}
        try:
            panel = self.panels.get(str(request.get("board")))
            if panel is None:
                raise UsageError(f"no board {request.get('board')!r} on this monitor")
            reply["data"] = await panel.perform(str(request.get("op")), request)
        except (ArduinoIOError, KeyError, TypeError, ValueError, OverflowError) as exc:
            # Bad input or a refusal (OverflowError: ``int()`` of an infinite float).
            logger.info("monitor: %s refused: %s", request.get("op"), exc)
            reply["ok"] = False
            reply["error"] = describe_error(exc)
        else:
            reply["ok"] = True
        return reply
