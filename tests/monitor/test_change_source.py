"""The monitor's change-event source on the fake board: every edge, losses, re-subscription.

The fake board models the firmware's change events (one GpioChange per edge of a watched
input, a sequence number per event, a bounded transmit buffer that drops what does not
fit), so each test has an oracle outside the monitor: the levels and edges the test
drove, and the events the fake board counted as dropped.  The sample stream is off in
these tests, so whatever the panel shows of an input came from change events.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

import anyio
import pytest

from arduinoio_async import D2, D3, D5, D6
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.testing import FakeBoard

pytestmark = pytest.mark.anyio
monitor = pytest.importorskip("arduinoio_async.monitor")

from arduinoio_async.monitor import BoardPanel  # noqa: E402  (after the extra's import check)
from arduinoio_async.monitor import _counts as counts  # noqa: E402


class Notified:
    """Wakes on the panel's change notifications, to wait for a condition of its state."""

    def __init__(self) -> None:
        self._event = anyio.Event()

    def poke(self) -> None:
        self._event.set()

    async def until(self, condition: Callable[[], bool], timeout: float = 5) -> None:
        with anyio.fail_after(timeout):
            while not condition():
                self._event = anyio.Event()
                await self._event.wait()


@asynccontextmanager
async def monitored(
    *, stream: bool = False, fake: FakeBoard | None = None
) -> AsyncIterator[tuple[Board, FakeBoard, BoardPanel, Notified]]:
    """A fake board, its Board, and a running panel (stream off unless asked)."""
    notified = Notified()
    async with (
        fake or FakeBoard(board_id=0x0042) as fake_board,
        Board.connect(fake_board.host_stream, timeout=0.5, ready_timeout=2) as board,
        anyio.create_task_group() as tg,
    ):
        panel = BoardPanel("b0", board, stream=stream, period_ms=10, on_change=notified.poke)
        tg.start_soon(panel.run)
        yield board, fake_board, panel, notified
        tg.cancel_scope.cancel()


def as_sent(message: dict[str, object] | None) -> Any:
    """The message as the page receives it (JSON)."""
    assert message is not None
    return json.loads(json.dumps(message))


def bit(pin: int) -> int:
    return 1 << pin


async def test_an_inputs_level_and_every_edge_come_from_its_change_events() -> None:
    async with monitored() as (_board, fake, panel, notified):
        fake.drive(5, True)
        assert (await panel.perform("role", {"pin": "D5", "role": "input"})) is None
        await notified.until(lambda: D5 in panel.changes.watched)
        # The starting level is read once; the stream never ran.
        await notified.until(lambda: panel.known & bit(5) != 0)
        assert panel.levels & bit(5) and not fake.stream.running
        for n in range(1, 31):  # faster than any stream period: only events count these
            fake.drive(5, False)
            fake.drive(5, True)
            await notified.until(lambda n=n: panel.rises[D5] == n)  # type: ignore[misc]
        assert panel.falls[D5] == 30 and panel.changes.lost == 0
        fake.drive(5, False)
        await notified.until(lambda: panel.falls[D5] == 31)
        message = as_sent(panel.take_samples())
        assert message["watched"] == bit(5) and message["known"] == bit(5)
        assert message["levels"] == 0
        assert (message["rises"][5 - 2], message["falls"][5 - 2]) == (30, 31)
        assert message["changes"]["pins"] == ["D5"] and message["changes"]["received"] == 61
        assert message["stream"]["running"] is False


async def test_events_the_board_dropped_show_as_lost_from_the_sequence_numbers() -> None:
    async with monitored() as (board, fake, panel, notified):
        await board.digital_input(D3)
        await notified.until(lambda: D3 in panel.changes.watched)
        for _ in range(20):  # 40 edges at once: the transmit buffer holds 17 of them
            fake.drive(3, True)
            fake.drive(3, False)
        dropped = fake.changes_dropped
        assert dropped > 0
        sent = 40 - dropped
        await notified.until(lambda: panel.changes.state.received == sent)
        fake.drive(3, True)  # the next event reveals the gap
        await notified.until(lambda: panel.changes.state.received == sent + 1)
        assert panel.changes.lost == dropped
        assert panel.rises[D3] + panel.falls[D3] == sent + 1
        assert panel.levels & bit(3)
        assert panel.changes.describe()["lost"] == dropped


async def test_subscriptions_follow_roles_and_end_with_the_monitor() -> None:
    fake = FakeBoard(board_id=0x0042)
    async with monitored(fake=fake) as (board, _fake, panel, notified):
        await panel.perform("role", {"pin": "D5", "role": "input"})
        await panel.perform("role", {"pin": "D6", "role": "input_pullup"})
        await notified.until(lambda: panel.changes.watched == {D5, D6})
        # An output is no input: its subscription ends, the other input keeps its own.
        await panel.perform("role", {"pin": "D6", "role": "output"})
        await notified.until(lambda: panel.changes.watched == {D5})
        sequence = fake.change_sequence
        await panel.perform("write", {"pin": "D6", "value": 1})
        assert fake.change_sequence == sequence  # no events from an output
        # A role set by a program that embeds the monitor is noticed too.
        await board.digital_input(D3)
        await notified.until(lambda: panel.changes.watched == {D3, D5})
        fake.drive(3, True)
        await notified.until(lambda: panel.rises[D3] == 1)
    # The monitor is gone: no pin is watched on the board any more.
    sequence = fake.change_sequence
    fake.drive(3, False)
    fake.drive(5, True)
    assert fake.change_sequence == sequence


async def test_a_reset_ends_the_boards_subscriptions_and_the_source_renews_them() -> None:
    async with monitored() as (board, fake, panel, notified):
        await panel.perform("role", {"pin": "D5", "role": "input"})
        await notified.until(lambda: D5 in panel.changes.watched)
        # Through the page: the source pauses around the reset.
        await panel.perform("reset", {})
        await notified.until(lambda: D5 in panel.changes.watched)
        fake.drive(5, True)
        await notified.until(lambda: panel.rises[D5] == 1)
        # Behind the monitor's back (as the manager restores a board that reset by
        # itself): the new session tag tells the source, which subscribes again (the
        # fake board, like the firmware, forgot every subscription in the reset).
        renewed = panel.changes.state.subscriptions
        await board.reset(restore=True)
        await notified.until(lambda: panel.changes.state.subscriptions > renewed)
        fake.drive(5, False)
        await notified.until(lambda: panel.falls[D5] == 1)
        assert not panel.levels & bit(5) and panel.rises[D5] == 1


async def test_a_firmware_without_change_events_keeps_the_streams_levels() -> None:
    async with monitored(stream=True) as (board, fake, panel, notified):
        caps = board.capabilities
        board.capabilities = dataclasses.replace(
            caps, features=caps.features & ~p.Feature.GPIO_CHANGES
        )
        await panel.perform("role", {"pin": "D5", "role": "input"})
        fake.drive(5, True)
        await notified.until(lambda: panel.levels & bit(5) != 0)
        assert panel.changes.watched == frozenset()
        described = as_sent(panel.changes.describe())
        assert described["supported"] is False and "not in this firmware" in described["error"]
        message = as_sent(panel.take_samples())
        assert message["watched"] == 0
        assert message["known"] & bit(5) and message["levels"] & bit(5)


@pytest.mark.parametrize(
    ("rate", "current", "every"),
    [
        (0, 1, 1),
        (50, 1, 1),
        (51, 1, 10),
        (500, 1, 10),
        (501, 1, 100),
        (20, 10, 1),  # fits every count with room to spare
        (30, 10, 10),  # would fit, but too near the boundary: no flapping
        (30, 100, 10),
        (1e9, 1, 10_000),
    ],
)
def test_the_report_interval_follows_the_counting_rate(
    rate: float, current: int, every: int
) -> None:
    assert counts.every_for(rate, current) == every


async def test_counts_come_from_counter_reports_and_follow_the_rate() -> None:
    async with monitored() as (_board, fake, panel, notified):
        assert (await panel.perform("role", {"pin": "D2", "role": "counter_rising"})) is None
        await notified.until(lambda: panel.counts.reported == {D2})
        await notified.until(lambda: panel.counters.get(D2) == 0)  # read once
        for n in range(1, 8):
            fake.drive(2, True)
            fake.drive(2, False)
            await notified.until(lambda n=n: panel.counters.get(D2) == n)  # type: ignore[misc]
        assert fake.counters[2] == 7 and not fake.stream.running
        assert await panel.perform("counter_reset", {"pin": "D2"}) == 7
        fake.drive(2, True)
        await notified.until(lambda: panel.counters.get(D2) == 1)
        message = as_sent(panel.take_samples())
        assert message["counters"] == [1, None] and message["reported"] == bit(2)
        assert message["counts"]["every"] == {"D2": 1}

        # A fast counter: the board reports every 10th (or 100th...) count instead.
        fast = anyio.Event()

        async def count_fast() -> None:
            while not fast.is_set():
                for _ in range(5):
                    fake.drive(2, False)
                    fake.drive(2, True)
                await anyio.sleep(0.001)  # a pulse train, not a wait for the monitor

        async with anyio.create_task_group() as tg:
            tg.start_soon(count_fast)
            await notified.until(lambda: panel.counts.state.every.get("D2", 1) > 1)
            fast.set()
        # Quiet again: every count is reported, and the count is exact once more.
        await notified.until(lambda: panel.counts.state.every.get("D2") == 1)
        await notified.until(lambda: panel.counters.get(D2) == fake.counters[2])
        fake.drive(2, False)
        fake.drive(2, True)
        await notified.until(lambda: panel.counters.get(D2) == fake.counters[2])


async def test_a_refused_subscription_shows_and_is_retried_until_the_board_takes_it() -> None:
    async with monitored() as (board, fake, panel, notified):
        await board.digital_input(D5)
        await board.digital_input(D6)
        await notified.until(lambda: panel.changes.watched == {D5, D6})
        # The board resets and nobody restores its roles: D5 is set up again on the board
        # alone, so D5's subscription works and D6's is refused.
        await board.reset()
        await board.request(p.GpioConfig(5, p.GpioFlags.INPUT))
        await notified.until(lambda: "the pin is not set up for that" in panel.changes.error)
        assert panel.changes.watched == frozenset()
        assert as_sent(panel.changes.describe())["running"] is False
        await board.restore()
        await notified.until(lambda: panel.changes.watched == {D5, D6})
        assert panel.changes.error == ""
        fake.drive(6, True)
        await notified.until(lambda: panel.rises[D6] == 1)
        fake.change_sequence += 3  # three events the board could not send
        fake.drive(5, True)
        await notified.until(lambda: panel.rises[D5] == 1)
        assert panel.changes.lost == 3  # counted once for the board, not once per pin


async def test_a_mega_page_follows_inputs_and_counters_past_d13() -> None:
    """D44 as an input and D18 (INT3) as a counter on a Mega: the page's level and count
    follow the fake's pins (the change and count sources were sized for the Uno's D2-D13
    and failed with a KeyError on D44)."""
    from arduinoio_async.protocol.boards import MEGA2560_FULL
    from arduinoio_async.protocol.pins import DigitalPin

    async with monitored(fake=FakeBoard(board_id=0x0042, model=MEGA2560_FULL)) as (
        _board,
        fake,
        panel,
        notified,
    ):
        await panel.perform("role", {"pin": "D44", "role": "input"})
        await panel.perform("role", {"pin": "D18", "role": "counter_rising"})
        fake.drive(44, True)
        await notified.until(lambda: bool(panel.levels & bit(44)))
        for level in (True, False, True):
            fake.drive(18, level)
        await notified.until(lambda: panel.counters.get(DigitalPin.D18) == 2)
