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

from tests import test_board
from tests.transport import test_serial_urls, test_transport

MODULES: list[ModuleType] = [test_transport, test_board, test_serial_urls]


def coroutine_tests() -> list[Any]:
    cases = []
    for module in MODULES:
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
