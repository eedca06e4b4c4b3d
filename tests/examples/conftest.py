"""A virtual Uno for the synchronous example tests (the FastAPI app's TestClient)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from anyio.from_thread import start_blocking_portal

from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno


@pytest.fixture
def virtual_uno_factory_sync(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[VirtualUno]]:
    """One virtual Uno (ID 5, loopback fixture) whose port is all ARDUINOIO_PORTS names."""
    uno = VirtualUno(board_id=5, fixture="loopback")
    with start_blocking_portal() as portal:
        try:
            portal.call(uno.start)
        except SimulatorNotAvailable as exc:
            if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
                raise
            pytest.skip(f"virtual Uno not available: {exc}")
        try:
            monkeypatch.setenv("ARDUINOIO_PORTS", uno.port)
            yield [uno]
        finally:
            portal.call(uno.stop)
