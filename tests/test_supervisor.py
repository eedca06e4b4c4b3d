"""The supervisor both the manager and the remote client run, on a fake board (no port).

The oracle is the fake board's own state (its pin roles, its session tag), never the
library's answer; every wait is on an event the supervisor emits.
"""

from __future__ import annotations

import logging

import anyio
import pytest

from arduinoio_async import D4
from arduinoio_async import protocol as p
from arduinoio_async._supervisor import (
    Events,
    LinkOutcome,
    ManagerEvent,
    retry_forever,
    supervise_link,
)
from arduinoio_async.board import Board
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.testing import FakeBoard

log = logging.getLogger(__name__)


class Recorder:
    """Every event, and an anyio.Event per kind set when the first of it arrives."""

    def __init__(self, events: Events) -> None:
        self.seen: list[ManagerEvent] = []
        self._first: dict[str, anyio.Event] = {}
        events.subscribe(self._on_event)

    def _on_event(self, event: ManagerEvent) -> None:
        self.seen.append(event)
        self.first(event.kind).set()

    def first(self, kind: str) -> anyio.Event:
        return self._first.setdefault(kind, anyio.Event())

    def kinds(self) -> list[str]:
        return [event.kind for event in self.seen]


def fresh() -> tuple[dict[int, Board], Events, Recorder]:
    """A board collection as a manager keeps one: the boards by ID, their news, a recorder."""
    events = Events(log)
    return {}, events, Recorder(events)


async def test_a_board_is_attached_restored_after_a_reset_and_detached_when_unplugged() -> None:
    boards, events, record = fresh()
    outcomes: list[LinkOutcome] = []
    async with FakeBoard(board_id=0x0031) as fake, anyio.create_task_group() as tg:
        link = await Board.start_link(fake.host_stream, timeout=0.5, ready_timeout=2)
        tg.start_soon(lambda: supervise_link(0x0031, link, boards, events, on_end=outcomes.append))
        await record.first("connected").wait()
        board = boards[0x0031]
        await board.digital_output(D4, initial=True)
        assert fake.session == board.session != 0

        fake.reboot()  # a reset by itself: RAM state gone
        assert fake.role(4) == "free"
        await record.first("reset").wait()
        while fake.role(4) != "output":  # the restore re-tags, then replays the roles
            await events.changed()
        assert fake.session == board.session != 0
        assert fake.levels[4] is True
        assert board.connected

        await fake.unplug()
        await record.first("disconnected").wait()
    assert record.kinds() == ["connected", "reset", "disconnected"]
    assert not board.connected
    (outcome,) = outcomes
    assert outcome.started and outcome.board is board and not outcome.rekeyed
    assert outcome.detail == record.seen[-1].detail != ""


async def test_a_board_back_under_another_id_is_given_up_not_restored() -> None:
    boards, events, record = fresh()
    async with FakeBoard(board_id=0x0011) as fake:
        link = await Board.start_link(fake.host_stream, timeout=0.5, ready_timeout=2)
        async with anyio.create_task_group() as tg:

            async def run() -> None:
                outcome = await supervise_link(0x0011, link, boards, events)
                assert outcome.rekeyed
                assert "0x0022" in outcome.detail.lower()

            tg.start_soon(run)
            await record.first("connected").wait()
            await boards[0x0011].digital_output(D4, initial=True)
            await boards[0x0011].request(p.WriteId(0x0022))  # behind the Board's back
            fake.reboot()
            await record.first("disconnected").wait()
        assert fake.role(4) == "free"  # 0x0011's role was not replayed on 0x0022


async def test_a_watch_that_returns_gives_the_link_up_with_its_reason() -> None:
    boards, events, record = fresh()
    give_up = anyio.Event()

    async def watch(board: Board) -> str:
        await give_up.wait()
        return "two servers announce it"

    async with FakeBoard(board_id=0x0005) as fake:
        link = await Board.start_link(fake.host_stream, timeout=0.5, ready_timeout=2)
        async with anyio.create_task_group() as tg:
            tg.start_soon(lambda: supervise_link(0x0005, link, boards, events, watch=watch))
            await record.first("connected").wait()
            give_up.set()
        assert record.seen[-1] == ManagerEvent(
            "disconnected", 0x0005, link.name, "two servers announce it"
        )
        assert not boards[0x0005].connected


async def test_a_failed_handshake_ends_unstarted_with_its_reason() -> None:
    boards, events, record = fresh()
    async with FakeBoard(board_id=0x0007) as fake:
        link = await Board.start_link(fake.host_stream, timeout=0.5, ready_timeout=2)
        await fake.unplug()  # gone before the handshake
        outcome = await supervise_link(0x0007, link, boards, events)
    assert not outcome.started and outcome.board is None and outcome.detail
    assert record.seen == []  # no board: nothing connected, nothing to disconnect


async def test_a_listener_that_raises_is_logged_and_the_others_still_hear(
    caplog: pytest.LogCaptureFixture,
) -> None:
    events = Events(log)
    heard: list[ManagerEvent] = []

    def broken(event: ManagerEvent) -> None:
        raise ValueError("listener bug")

    events.subscribe(broken)
    unsubscribe = events.subscribe(heard.append)
    event = ManagerEvent("connected", 1, "port")
    events.emit(event)
    assert heard == [event]
    assert "listener bug" in caplog.text
    unsubscribe()
    events.emit(event)
    assert heard == [event]


async def test_retry_forever_retries_a_failure_after_its_pause_and_raises_a_bug() -> None:
    attempts: list[float] = []  # when each attempt ran
    third = anyio.Event()

    async def failing() -> None:
        attempts.append(anyio.current_time())
        if len(attempts) == 3:
            third.set()
        raise ArduinoIOError("not answering")

    with anyio.move_on_after(5):
        async with anyio.create_task_group() as tg:
            tg.start_soon(lambda: retry_forever(failing, pause=0.01, what="board"))
            await third.wait()
            tg.cancel_scope.cancel()
    assert len(attempts) >= 3

    async def buggy() -> None:
        raise KeyError("a bug")

    with pytest.raises(KeyError):
        await retry_forever(buggy, pause=0.01, what="board")


async def test_retry_forever_checkpoints_even_when_every_attempt_returns_at_once() -> None:
    """An attempt that never suspends must not keep a cancel out: the pause is a checkpoint."""
    calls = 0

    async def instant() -> None:
        nonlocal calls
        calls += 1

    with anyio.move_on_after(0.05) as scope:
        await retry_forever(instant, pause=0, what="board")
    assert scope.cancelled_caught and calls >= 1
