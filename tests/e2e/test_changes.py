"""Input change events on the virtual Uno (protocol extension, docs/protocol.md 7.4)."""

from __future__ import annotations

import itertools
import statistics

import anyio
import pytest

from arduinoio_async import D2, D3
from arduinoio_async.board import Board
from arduinoio_async.board.changes import Change, ChangeStream
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: Fixed cost of an event on an idle board, from the pin change to the timestamp: the
#: interrupt's entry (4 cycles plus the instruction running), its prologue, reading the
#: ports, comparing, and hal_micros() reading the clock: about 120 cycles, 7.5 us.
IDLE_DETECTION_US = 8


async def collect(changes: ChangeStream, count: int, within: float) -> list[Change]:
    got: list[Change] = []
    with anyio.fail_after(within):
        async for change in changes:
            got.append(change)
            if len(got) == count:
                break
    return got


async def test_1khz_toggling_loses_no_change_and_each_is_seen_within_0_2_ms(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """The fixture's pulse generator toggles D3 at 1 kHz (2,000 edges a second) for 1 s
    while four tasks keep requests in flight: events and replies share the line."""
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    pulses = 1000
    replies = 0
    async with (
        Board.open(uno.port, baudrate=uno.baud) as board,
        board.gpio(D3).watch(buffer=10 * pulses) as changes,
    ):

        async def reader() -> None:
            nonlocal replies
            while True:
                assert await board.read_id() == 1
                replies += 1

        async with anyio.create_task_group() as tg:
            for _ in range(4):
                tg.start_soon(reader)
            await uno.clear_pulse_stats("D3")
            await uno.pulses("D3", count=pulses, high_us=500, low_us=500)
            got = await collect(changes, 2 * pulses, within=20)
            tg.cancel_scope.cancel()
        stats = await uno.pulse_stats("D3")
    assert replies > 100
    assert changes.gaps == changes.dropped == 0
    assert [c.sequence for c in got] == list(range(2 * pulses))
    assert [c.level for c in got] == [True, False] * pulses
    # The generator's edges (simulated time) against the board's timestamps of the same
    # edges: the board clock and the simulated clock advance together, so their offset
    # (the board's boot time) is constant; it is taken from the quickest event and the
    # idle board's fixed detection cost added.
    rises = [c.board_time_us for c in got if c.rose][-len(stats.rise_us) :]
    falls = [c.board_time_us for c in got if c.fell][-len(stats.rise_us) :]
    edge_falls = [r + h for r, h in zip(stats.rise_us, stats.high_us, strict=True)]
    offsets = [b - e for b, e in zip(rises, stats.rise_us, strict=True)]
    offsets += [b - e for b, e in zip(falls, edge_falls, strict=True)]
    assert len(offsets) >= 32
    latency = [o - min(offsets) + IDLE_DETECTION_US for o in offsets]
    print(
        f"\nchange detection latency over {len(latency)} edges: median "
        f"{statistics.median(latency):.1f} us, max {max(latency):.1f} us "
        f"({replies} requests answered meanwhile)"
    )
    assert max(latency) <= 200
    # consecutive edges keep the generator's spacing on the board's clock
    spacing = [b.board_time_us - a.board_time_us for a, b in itertools.pairwise(got)]
    assert all(abs(s - 500) <= 200 for s in spacing), (min(spacing), max(spacing))


async def test_a_write_on_d2_arrives_as_a_change_of_its_jumper_d3(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, fixture="loopback")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        out = board.gpio(D2)
        await out.write(False)
        async with board.gpio(D3).watch() as changes:
            for level in (True, False, True):
                await out.write(level)
                with anyio.fail_after(2):
                    change = await changes.__anext__()
                assert (change.pin, change.level) == (3, level)
        assert changes.gaps == 0
        # the subscription ended with the block: the level is read, no event follows
        await out.write(False)
        assert (await board.gpio(D3).read()).fell
        assert changes.pending() == 0


async def test_a_counter_reports_every_10_generated_pulses(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        counter = await board.counter(D2)
        async with counter.reports(every=10) as reports:
            await uno.pulses("D2", count=1000, high_us=200, low_us=300)  # 2 kHz for 0.5 s
            got = []
            with anyio.fail_after(20):
                async for report in reports:
                    got.append(report)
                    if len(got) == 100:
                        break
        assert [r.count for r in got] == list(range(10, 1001, 10))
        assert reports.missed == reports.dropped == 0
        spacing = [b.timestamp_us - a.timestamp_us for a, b in itertools.pairwise(got)]
        assert all(abs(s - 5000) <= 50 for s in spacing), (min(spacing), max(spacing))
        assert await counter.read() == 1000
