"""BoardManager against virtual Unos: discovery, duplicates, unplug/replug, resets."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import anyio
import pytest

from arduinoio_async import (
    D4,
    D9,
    BoardDisconnectedError,
    BoardNotFoundError,
    DuplicateBoardError,
)
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import fresh_pulses

pytestmark = pytest.mark.sim


def manager(ports: list[str], **options: Any) -> BoardManager:
    """A manager that looks only at ``ports`` (no USB listing, no environment)."""
    return BoardManager(ports=ports, usb=False, env=False, **options)


@contextmanager
def garbage_port() -> Iterator[str]:
    """A pseudo-terminal whose far end answers every write with bytes of another protocol."""
    master, slave = os.openpty()
    path = os.ttyname(slave)
    os.close(slave)
    stop = threading.Event()

    def answer() -> None:
        os.set_blocking(master, False)
        while not stop.is_set():
            try:
                if os.read(master, 64):
                    os.write(master, b"$GPGGA,garbage*7F\r\n")
            except (BlockingIOError, OSError):
                time.sleep(0.002)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    try:
        yield path
    finally:
        stop.set()
        thread.join()
        os.close(master)


def open_fds_to(path: str) -> list[str]:
    real = os.path.realpath(path)
    found = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            if os.path.realpath(f"/proc/self/fd/{fd}") == real:
                found.append(fd)
        except OSError:
            continue
    return found


async def test_three_boards_are_found_concurrently(virtual_uno_factory: VirtualUnoFactory) -> None:
    unos = []
    for board_id in (1, 2, 3):
        unos.append(await virtual_uno_factory(board_id=board_id, reset_on_open=True))
    start = time.perf_counter()
    async with manager([unos[0].port], probe_deadline=5) as boards:
        one = time.perf_counter() - start
        assert set(boards.present()) == {1}
    start = time.perf_counter()
    async with manager([u.port for u in unos], probe_deadline=5) as boards:
        three = time.perf_counter() - start
        assert set(boards.present()) == {1, 2, 3}
        for board_id in (1, 2, 3):
            board = await boards.get(board_id)
            assert await board.read_id() == board_id
    print(f"\ndiscovery with auto-reset on open: one board {one:.3f} s, three boards {three:.3f} s")


async def test_a_port_speaking_something_else_is_skipped_and_closed(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=5)
    with garbage_port() as foreign:
        async with manager([foreign, uno.port], probe_deadline=0.5) as boards:
            assert set(boards.present()) == {5}
            result = boards.probed()[foreign]
            assert not result.ok and "did not answer" in result.error
            assert "24 47 50" in result.error  # what it said instead ("$GP...")
            assert open_fds_to(foreign) == []


async def test_duplicate_ids_are_reported_with_both_ports(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    first = await virtual_uno_factory(board_id=7)
    second = await virtual_uno_factory(board_id=7)
    async with manager([first.port, second.port]) as boards:
        with pytest.raises(DuplicateBoardError) as info:
            await boards.get(7, timeout=1)
        assert set(info.value.ports) == {first.port, second.port}


async def test_a_missing_id_names_the_ports_tried(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with manager([uno.port, "/dev/does-not-exist"]) as boards:
        with pytest.raises(BoardNotFoundError) as info:
            await boards.get(0x0042, timeout=0.5)
        assert set(info.value.tried) == {uno.port, "/dev/does-not-exist"}
        assert "0x0042" in str(info.value) and "board 0x0001" in str(info.value)


async def test_unplug_fails_at_once_and_replug_restores_the_same_handles(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=9)
    events: list[ManagerEvent] = []
    async with manager([uno.port], rescan_interval=0.05) as boards:
        boards.subscribe(events.append)
        board = await boards.get(9)
        led = board.gpio(D4)
        servo = await board.servo(D9, pulse_us=1500)
        await servo.set_pulse(1800)
        failure: list[BaseException] = []
        writes = 0

        async def writer() -> None:
            nonlocal writes
            level = False
            while True:
                level = not level
                try:
                    await led.write(level)
                except BoardDisconnectedError as exc:
                    failure.append(exc)
                    return
                writes += 1
                await anyio.sleep(0.003)

        with anyio.fail_after(2):  # a hang guard: the failure must come at once
            async with anyio.create_task_group() as tg:
                tg.start_soon(writer)
                await anyio.sleep(0.05)
                await uno.unplug()
        assert writes > 5 and isinstance(failure[0], BoardDisconnectedError)
        assert not board.connected
        new_port = await uno.replug()
        boards.add_port(new_port)
        with anyio.fail_after(10):
            again = await boards.wait_connected(9)
        assert again is board and board.port == new_port
        assert (await uno.pin("D9")).ddr == 1
        stats = await fresh_pulses(uno, "D9", 2)
        assert stats.high_us and all(abs(h - 1800) <= 1 for h in stats.high_us[1:]), stats
        last = (await uno.pin("D4")).level
        await led.write(not last)  # the same handle works again
        assert (await uno.pin("D4")).level == (not last)
        kinds = [e.kind for e in events]
        assert kinds.index("disconnected") < kinds.index("connected")


async def test_a_reset_by_command_is_detected_and_restored(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=4)
    events: list[ManagerEvent] = []
    async with manager([uno.port]) as boards:
        boards.subscribe(events.append)
        board = await boards.get(4)
        await board.gpio(D4).write(True)
        await board.request(p.Reset())  # behind the library's back
        with anyio.fail_after(5):
            while not any(e.kind == "reset" for e in events) or not board.connected:  # noqa: ASYNC110
                await anyio.sleep(0.02)
        assert (await uno.pin("D4")).level == 1  # restored before the board was handed back
        status = await board.status()
        assert status.session == board.session


async def test_a_restore_that_fails_drops_only_that_board(
    virtual_uno_factory: VirtualUnoFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A board resets and its restore fails (the line goes dead as it starts, then the
    cable is pulled): the manager reports the loss and keeps serving the other board; no
    ExceptionGroup escapes ``async with BoardManager()``."""
    resetting = await virtual_uno_factory(board_id=4)
    other = await virtual_uno_factory(board_id=5)
    adopt = Board.adopt

    async def unplug_then_adopt(board: Board, link: Any) -> None:
        if board.board_id == 4:
            await resetting.set_faults(drop=1.0)  # every reply lost: the restore times out
        await adopt(board, link)

    events: list[ManagerEvent] = []
    async with manager([resetting.port, other.port], rescan_interval=None) as boards:
        boards.subscribe(events.append)
        board = await boards.get(4)
        survivor = await boards.get(5)
        await board.gpio(D4).write(True)
        monkeypatch.setattr(Board, "adopt", unplug_then_adopt)
        await board.request(p.Reset())  # behind the library's back
        with anyio.fail_after(10):
            while not any(e.kind == "reset" for e in events):  # noqa: ASYNC110
                await anyio.sleep(0.02)
        await resetting.unplug()
        with anyio.fail_after(10):
            while not any(e.kind == "disconnected" and e.board_id == 4 for e in events):  # noqa: ASYNC110
                await anyio.sleep(0.02)
        lost = next(e for e in events if e.kind == "disconnected")
        assert "closed" in lost.detail or "lost" in lost.detail, lost.detail  # says why
        assert not board.connected
        assert await survivor.read_id() == 5  # the other board stays
