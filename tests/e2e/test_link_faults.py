"""The real firmware over a faulty line and through a reset mid-command.

The invariant of the transport tests, on the virtual Uno: every call returns its own
correct answer or raises a documented exception; nothing hangs.
"""

from __future__ import annotations

from typing import Any

import anyio
import pytest

from arduinoio_async import A1, D3, LinkError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.protocol.pins import DigitalPin
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def test_flipped_dropped_and_inserted_bytes(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=0x0077, baud=1_000_000, seed=11)
    await uno.set_analog(1, 3000)
    async with Board.open(uno.port, baudrate=uno.baud, timeout=0.2) as board:
        await board.digital_output(D3, initial=True)
        # Rare enough that two faults in one frame (which an 8-bit XOR could miss) stay
        # improbable; common enough to resync dozens of times.
        await uno.set_faults(drop=0.001, insert=0.001, flip=0.001)
        ok = failed = 0
        with anyio.fail_after(60):
            for _ in range(800):
                try:
                    assert await board.read_id() == 0x0077
                    assert abs(await board.analog(A1).read() - 614) <= 2
                    assert (await board.request(p.GpioRead(3))).level
                    ok += 1
                except LinkError:
                    failed += 1
        await uno.set_faults(drop=0, insert=0, flip=0)
        assert await board.read_id() == 0x0077
        stats = board.link.stats
        print(
            f"\n{ok} clean rounds, {failed} failed with LinkError, {stats.resyncs} resyncs, "
            f"{stats.garbage_bytes} garbage bytes"
        )
        assert ok > 600 and failed > 0 and stats.resyncs > 0


async def test_a_board_reset_mid_command(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=0x0078)
    async with Board.open(uno.port, timeout=0.3) as board:
        errors: list[Exception] = []

        async def hammer() -> None:
            with anyio.move_on_after(1.5):
                while True:
                    try:
                        assert await board.read_id() == 0x0078
                    except LinkError as exc:
                        errors.append(exc)

        async with anyio.create_task_group() as tg:
            tg.start_soon(hammer)
            await anyio.sleep(0.2)
            await uno.reset()
        # A read in flight at the reset may fail, or be retried transparently (ReadId is
        # idempotent); either way the board is back and the host can tell it rebooted.
        assert all(isinstance(e, LinkError) for e in errors)
        assert await board.read_id() == 0x0078
        assert (await board.status()).session == 0  # a fresh boot: the host can tell


async def test_transactions_from_many_tasks_over_a_faulty_line(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """40 tasks, transactions of writes and reads at 2e-3 line faults (a short version of
    benchmarks/tx_soak.py): every returned item is what the fixture says (the pin probe,
    the values read on the clean line), every failure a LinkError, and losses stay those
    of single requests (before the reply's SEQ and per-item checks, an ambiguous reply
    failed everything in flight: 66 % succeeded)."""
    uno = await virtual_uno_factory(board_id=0x0079, baud=1_000_000, seed=5)
    for channel, mv in ((0, 1000.0), (1, 2500.0), (2, 4000.0)):
        await uno.set_analog(channel, mv)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        pins = list(range(4, 14))
        for pin in pins:
            await board.digital_output(DigitalPin(pin))
        truth = {
            r: await board.request(r)
            for r in (p.AnalogRead(0), p.AnalogRead(1), p.AnalogRead(2), p.ReadId())
        }
        await uno.set_faults(drop=0.002, insert=0.002, flip=0.002)
        ok = failed = 0
        wrong: list[str] = []

        async def worker(index: int) -> None:
            nonlocal ok, failed
            level = False
            for step in range(15):
                level = not level
                requests: list[p.Request[Any]] = [p.AnalogRead(step % 3), p.ReadId()]
                if index < len(pins):
                    requests.insert(0, p.GpioWrite(pins[index], level))
                try:
                    async with board.transaction() as tx:
                        items = [tx.add(r) for r in requests]
                    replies = [item.result() for item in items]
                except LinkError:
                    failed += 1
                    continue
                ok += 1
                for request, reply in zip(requests, replies, strict=True):
                    if request in truth and reply != truth[request]:
                        wrong.append(f"{request!r} -> {reply!r}")
                if index < len(pins) and (await uno.pin(pins[index])).level != int(level):
                    wrong.append(f"D{pins[index]} is not {level}")

        with anyio.fail_after(120):
            async with anyio.create_task_group() as tg:
                for index in range(40):
                    tg.start_soon(worker, index)
        await uno.set_faults(drop=0, insert=0, flip=0)
        stats = board.link.stats
        print(f"\n{ok} transactions ok, {failed} LinkError, {stats.retries} retries")
        assert wrong == []
        assert stats.retries > 0  # the line's faults did reach transactions
        assert ok >= 0.95 * (ok + failed)
