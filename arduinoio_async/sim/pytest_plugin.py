"""pytest fixture ``virtual_uno_factory``: start virtual Unos that are stopped after the test.

Installing the package registers it with pytest (``pytest11`` entry point), so any test
suite in that environment can use the fixture; ``pytest_plugins =
["arduinoio_async.sim.pytest_plugin"]`` loads it explicitly.  When the simulator
is not built or simavr is missing, tests using the fixture are *skipped* with the reason
(so the suite still runs on machines without simavr); set ``ARDUINOIO_SIM_REQUIRED=1`` to
make that a failure instead, e.g. in CI where the simulator must be present.

The fixture is async, so it needs pytest-asyncio; but this module is loaded by *every*
pytest run in an environment where the package is installed, so it must load without
it.  Without pytest-asyncio the fixture still exists, and a test that asks for it errors
with the line to run (``pip install pytest-asyncio``) instead of pytest failing to start.
"""

from __future__ import annotations

import os
from collections.abc import AsyncIterator
from typing import Any, Protocol

import pytest

from .harness import SimulatorNotAvailable
from .virtual_uno import VirtualUno

__all__ = ["VirtualUnoFactory", "virtual_uno_factory"]


class VirtualUnoFactory(Protocol):
    """Starts a board with :class:`VirtualUno` keyword options and returns it running."""

    async def __call__(self, **options: Any) -> VirtualUno: ...


INSTALL_HINT = (
    "the virtual_uno_factory fixture is async and needs pytest-asyncio: pip install pytest-asyncio"
)


async def _virtual_uno_factory() -> AsyncIterator[VirtualUnoFactory]:
    """Function-scoped factory; every board it started is stopped when the test ends."""
    boards: list[VirtualUno] = []

    async def factory(**options: Any) -> VirtualUno:
        board = VirtualUno(**options)
        try:
            await board.start()
        except SimulatorNotAvailable as exc:
            if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
                raise
            pytest.skip(f"virtual Uno not available: {exc}")
        boards.append(board)
        return board

    try:
        yield factory
    finally:
        for board in reversed(boards):
            await board.stop()


def _needs_pytest_asyncio() -> None:
    pytest.fail(INSTALL_HINT, pytrace=False)


virtual_uno_factory: Any
try:
    import pytest_asyncio
except ModuleNotFoundError:
    virtual_uno_factory = pytest.fixture(name="virtual_uno_factory")(_needs_pytest_asyncio)
else:
    virtual_uno_factory = pytest_asyncio.fixture(name="virtual_uno_factory")(_virtual_uno_factory)
