"""The transport and board tests again, on trio (pytest-asyncio runs them on asyncio).

The library uses anyio's portable primitives only; on trio the serial stream waits with
``wait_readable`` and the transport runs a reader task instead of the asyncio
fd-readable callback.  Every coroutine test of the two modules runs here unchanged.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Coroutine
from types import ModuleType
from typing import Any

import anyio
import pytest

from arduinoio_async import D2
from arduinoio_async.board import Board
from arduinoio_async.errors import BoardDisconnectedError
from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno
from tests import test_board
from tests.transport import test_fast_path, test_serial_urls, test_transport

MODULES: list[ModuleType] = [test_transport, test_board, test_serial_urls, test_fast_path]


def coroutine_tests(modules: list[ModuleType] = MODULES) -> list[Any]:
    cases = []
    for module in modules:
        for name, func in vars(module).items():
            if (
                name.startswith("test_")
                and inspect.iscoroutinefunction(func)
                and not inspect.signature(func).parameters
            ):
                cases.append(pytest.param(func, id=f"{module.__name__.rsplit('.', 1)[1]}::{name}"))
    return cases


@pytest.mark.parametrize("test", coroutine_tests())
def test_on_trio(test: Callable[[], Coroutine[Any, Any, None]]) -> None:
    anyio.run(test, backend="trio")


@pytest.mark.sim
def test_a_serial_board_on_trio() -> None:
    """The landed serial stream used asyncio internals: ``RuntimeError: no running event
    loop`` on trio.  A virtual Uno on its pty, with concurrent calls and an unplug."""

    async def scenario() -> None:
        try:
            uno = await VirtualUno(board_id=7, baud=1_000_000).start()
        except SimulatorNotAvailable as exc:
            pytest.skip(f"virtual Uno not available: {exc}")
        try:
            async with Board.open(uno.port, baudrate=1_000_000) as board:
                await board.gpio(D2).write(True)
                assert (await uno.pin(2)).level == 1
                ids: list[int] = []

                async def read() -> None:
                    ids.append(await board.read_id())

                async with anyio.create_task_group() as tg:
                    for _ in range(16):
                        tg.start_soon(read)
                assert ids == [7] * 16
                await uno.unplug()
                with pytest.raises(BoardDisconnectedError):
                    await board.read_id()
        finally:
            with anyio.CancelScope(shield=True):
                await uno.stop()

    anyio.run(scenario, backend="trio")
