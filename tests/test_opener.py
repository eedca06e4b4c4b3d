"""One opener reads every address; ``Board.open`` hands what it does not open itself to the
opener registered for the address's scheme (the board layer never imports the network)."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import pytest

import arduinoio_async
from arduinoio_async import _schemes, open_board
from arduinoio_async.board import Board
from arduinoio_async.errors import UsageError


def test_the_package_registers_the_network_scheme() -> None:
    assert _schemes.opener_for("zenoh://0x0007") is not None
    assert _schemes.opener_for("ZENOH://0x0007@tcp/10.0.0.2:7447") is not None
    assert _schemes.opener_for("/dev/ttyACM0") is None
    assert _schemes.opener_for("socket://localhost:5000") is None  # pyserial's, opened here
    assert arduinoio_async.open_board is open_board


async def test_board_open_hands_a_registered_scheme_to_its_opener() -> None:
    seen: list[tuple[str, dict[str, Any]]] = []

    @asynccontextmanager
    async def opener(address: str, **options: Any) -> AsyncIterator[Any]:
        seen.append((address, options))
        yield "the board"

    _schemes.register("test-scheme", opener)
    try:
        async with Board.open("test-scheme://7", timeout=0.25, ready_timeout=1.5) as board:
            assert board == "the board"  # type: ignore[comparison-overlap]
    finally:
        _schemes._OPENERS.pop("test-scheme")
    assert seen == [("test-scheme://7", {"timeout": 0.25, "ready_timeout": 1.5})]


async def test_local_port_options_for_a_served_board_are_refused() -> None:
    with pytest.raises(UsageError, match="baudrate, low_latency: options of a local port"):
        async with open_board("zenoh://0x0007", baudrate=115200, low_latency=True):
            pass  # pragma: no cover
