"""``arduinoio list --remote``: the boards a server announces, as ``list`` shows local ones."""

from __future__ import annotations

import json
import sys

import anyio
import pytest

from arduinoio_async import protocol as p

from .conftest import ServeFactory, free_endpoint

pytestmark = pytest.mark.sim


async def arduinoio(*argv: str) -> tuple[int, str, str]:
    """The command in its own process, as a user runs it."""
    result = await anyio.run_process([sys.executable, "-m", "arduinoio_async", *argv], check=False)
    return result.returncode, result.stdout.decode(), result.stderr.decode()


async def test_list_remote_shows_the_served_boards(serve_unos: ServeFactory) -> None:
    async with serve_unos([7, 9]) as served:
        code, out, err = await arduinoio("list", "--remote", "--connect", served.endpoint, "--json")
        assert code == 0, err
        rows = {row["id"]: row for row in json.loads(out)}
        assert set(rows) == {7, 9}
        assert rows[7]["port"] == "zenoh://0x0007" and rows[7]["status"] == "ok"
        assert rows[9]["protocol"] == p.PROTOCOL_VERSION and rows[9]["baud"] == p.DEFAULT_BAUD
        code, out, err = await arduinoio("list", "--remote", "--connect", served.endpoint)
        assert code == 0 and "0x0007" in out and "0x0009" in out, err


async def test_list_remote_with_no_server_says_none_answered() -> None:
    code, _, err = await arduinoio(
        "list", "--remote", "--connect", free_endpoint(), "--probe-timeout", "1"
    )
    assert code == 1
    assert "no board is served" in err and "Traceback" not in err
