"""The harness's control channel dispatches through its command table (firmware/sim/control.c).

Raw request lines on a second control connection, so the exact reply bytes are checked:
every command the README documents reaches a handler, and what is not a command gets the
same JSON errors as before the table replaced the ``strcmp`` chain.
"""

from __future__ import annotations

import re
from pathlib import Path

import anyio
import anyio.abc
from anyio.streams.buffered import BufferedByteReceiveStream

from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .conftest import start_test_board

README = Path(__file__).resolve().parents[2] / "firmware" / "sim" / "README.md"


class RawControl:
    """One control connection that sends lines as given and returns reply lines as bytes."""

    def __init__(self, stream: anyio.abc.SocketStream) -> None:
        self.stream = stream
        self.reader = BufferedByteReceiveStream(stream)

    async def ask(self, line: bytes) -> bytes:
        await self.stream.send(line + b"\n")
        with anyio.fail_after(5):
            return await self.reader.receive_until(b"\n", 1 << 20)


def _documented_commands() -> list[str]:
    table = README.read_text().split("## Control channel", 1)[1]
    names = re.findall(r'^\| `\{"cmd": "(\w+)"', table, flags=re.MULTILINE)
    assert len(names) >= 15, names  # the README's request table was found
    return names


def _unknown(name: bytes) -> bytes:
    return b'{"ok": false, "error": "unknown cmd: ' + name + b'"}'


async def test_unknown_and_malformed_requests_get_the_documented_errors(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await start_test_board(virtual_uno_factory)
    async with await anyio.connect_unix(uno.control_path) as stream:
        control = RawControl(stream)
        assert await control.ask(b'{"cmd": "nope"}') == _unknown(b"nope")
        # quotes, backslashes and control characters are left out of the echoed name
        reply = await control.ask(b'{"cmd": "no\\"pe\\\\\\tx"}')
        assert reply == _unknown(b"nopex")
        assert await control.ask(b"{}") == b'{"ok": false, "error": "missing cmd"}'
        assert await control.ask(b'{"cmd": 5}') == b'{"ok": false, "error": "missing cmd"}'
        assert await control.ask(b"not json") == b'{"ok": false, "error": "bad JSON object"}'
        assert await control.ask(b'{"command": "ping"}') == b'{"ok": true}'
        # a prefix or a longer name is not a command
        assert await control.ask(b'{"cmd": "pin_"}') == _unknown(b"pin_")
        assert await control.ask(b'{"cmd": "eeprom_"}') == _unknown(b"eeprom_")


async def test_every_documented_command_reaches_its_handler(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await start_test_board(virtual_uno_factory)
    async with await anyio.connect_unix(uno.control_path) as stream:
        control = RawControl(stream)
        for name in _documented_commands():
            reply = await control.ask(b'{"cmd": "%s"}' % name.encode())
            assert b"unknown cmd" not in reply, (name, reply)
            assert reply.startswith(b'{"ok": '), (name, reply)
        # the replies of the two commands that once shared a handler by name
        eeprom = await control.ask(b'{"cmd": "eeprom", "offset": 1016, "length": 8}')
        assert eeprom.startswith(b'{"ok": true, "offset": 1016, "bytes": [')
        i2c = await control.ask(b'{"cmd": "eeprom_i2c", "offset": 250, "length": 8}')
        assert i2c == b'{"ok": false, "error": "range outside 0..256"}'
        assert await control.ask(b'{"cmd": "clear_pulse_stats", "pin": "D9"}') == b'{"ok": true}'
        stats = await control.ask(b'{"cmd": "pulse_stats", "pin": "D9"}')
        assert stats.startswith(b'{"ok": true, "pin": 9, "count": 0, "falls": 0, ')
