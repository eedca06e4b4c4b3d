"""A page's bad messages are refused one by one; none reaches the server as a traceback.

Each used to escape the WebSocket handler's parsing or ``MonitorHub.perform`` and end the
page's connection with a traceback from uvicorn: a number beyond a float's range
(``Infinity``, ``1e400``: ``OverflowError`` in ``int()``), deeply nested JSON
(``RecursionError``), an integer of more digits than Python converts (``ValueError``
outside ``JSONDecodeError``) and a binary frame (``KeyError: 'text'``).  Now each gets a
one-line ``result`` error to that page and a log line, and the page goes on working.
"""

from __future__ import annotations

import json
import logging
from typing import Any

import pytest

from .test_server import fake_monitor, page, ws_url

monitor = pytest.importorskip("arduinoio_async.monitor")
ws_errors = pytest.importorskip("websockets.exceptions")

BAD_MESSAGES: dict[str, str | bytes] = {
    "infinity": '{"id": 1, "board": "b0", "op": "pulse", "pin": "D9", "us": Infinity}',
    "1e400": '{"id": 2, "board": "b0", "op": "write", "pin": "D2", "value": 1e400}',
    "nan": '{"id": 3, "board": "b0", "op": "pulse", "pin": "D9", "us": NaN}',
    "nested": "[" * 20_000 + "]" * 20_000,
    "long integer": '{"id": 4, "board": "b0", "op": "pulse", "pin": "D9", "us": '
    + "9" * 5000
    + "}",
    "binary": b'{"id": 5, "board": "b0", "op": "reset"}',
    "not an object": "[1, 2, 3]",
    "not json": "hello",
}


@pytest.mark.parametrize("name", list(BAD_MESSAGES))
async def test_a_bad_message_gets_a_one_line_error_and_the_page_goes_on(
    name: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO)
    async with fake_monitor() as (fake, server), page(ws_url(server)) as tab:
        assert (await tab.call("role", pin="D9", role="servo"))["ok"]
        assert (await tab.call("role", pin="D2", role="output"))["ok"]
        for message in [BAD_MESSAGES[name]] * 2:
            caplog.clear()
            await tab.connection.send(message)
            reply: dict[str, Any] = await tab.receive("result")
            assert reply["ok"] is False, (name, reply)
            error = reply["error"]
            assert isinstance(error, str) and error and "\n" not in error, (name, error)
            assert len(error) < 200, (name, error)
            refused = [r for r in caplog.records if r.name.startswith("arduinoio_async.monitor")]
            assert len(refused) == 1 and "\n" not in refused[0].getMessage(), (name, refused)
            assert not [r for r in caplog.records if r.exc_info], name
            # The page goes on: a good request on the same connection is answered.
            assert (await tab.call("pulse", pin="D9", us=1200))["ok"], name
        assert fake.pulses[9] == 1200
        assert fake.levels[2] is False


async def test_a_message_beyond_the_size_limit_closes_only_that_page() -> None:
    async with fake_monitor() as (_fake, server), page(ws_url(server)) as good:
        async with page(ws_url(server)) as flooder:
            await flooder.connection.send(json.dumps({"id": 1, "pad": "x" * (2 << 20)}))
            with pytest.raises(ws_errors.ConnectionClosed) as closed:
                await flooder.receive("never")
            assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009
        assert (await good.call("role", pin="D4", role="output"))["ok"]
