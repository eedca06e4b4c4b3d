"""The ``arduinoio`` command against virtual Unos, through ``main(argv)``."""

from __future__ import annotations

import io
import json
import os
import select
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import anyio
import pytest
import serial
from rich.console import Console

from arduinoio_async import (
    A0,
    A1,
    A2,
    A3,
    D4,
    Board,
    BoardManager,
    BoardNotFoundError,
    LinkCapacityError,
    manager,
)
from arduinoio_async import protocol as p
from arduinoio_async.cli import main
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def run(*argv: str) -> tuple[int, str]:
    """Run the command in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=200)
    code = await anyio.to_thread.run_sync(lambda: main(list(argv), console=console))
    return code, buffer.getvalue()


async def test_list_finds_the_boards(virtual_uno_factory: VirtualUnoFactory) -> None:
    one = await virtual_uno_factory(board_id=1)
    two = await virtual_uno_factory(board_id=2)
    code, out = await run("list", "--json", "--ports", one.port, "--ports", two.port)
    assert code == 0
    rows = {row["port"]: row for row in json.loads(out)}
    assert rows[one.port]["id"] == 1 and rows[two.port]["id"] == 2
    assert rows[one.port]["protocol"] == 1 and rows[one.port]["baud"] == p.DEFAULT_BAUD
    code, out = await run("list", "--ports", one.port)
    assert code == 0 and "0x0001" in out


async def test_info_and_missing_id(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(board_id=2)
    code, out = await run("info", "--id", "2", "--ports", uno.port)
    assert code == 0 and "0x0002" in out and "temperature" in out
    code, _ = await run("info", "--id", "0x99", "--ports", uno.port, "--probe-timeout", "1")
    assert code == 1
    assert "no board with ID 0x0099" in capsys.readouterr().err


async def test_pin_commands_change_the_fixture(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, out = await run("write", "--port", uno.port, "D4", "1")
    assert code == 0 and (await uno.pin("D4")).level == 1
    await uno.drive("D5", 1)
    code, out = await run("read", "--port", uno.port, "D5")
    assert code == 0 and "level 1" in out
    code, _ = await run("servo", "--port", uno.port, "D9", "1500")
    assert code == 0 and (await uno.pin("D9")).ddr == 1
    code, _ = await run("servo", "--port", uno.port, "D6", "1200")
    assert code == 0
    await uno.set_analog(0, 2500)
    code, out = await run("analog", "--port", uno.port, "A0")
    assert code == 0 and "A0: 51" in out
    code, out = await run("analog", "--port", uno.port)
    assert code == 0 and "A5:" in out


async def test_i2c_write_and_read(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, _ = await run("i2c", "write", "0x50", "0x10", "1", "2", "3", "--port", uno.port)
    assert code == 0
    code, out = await run("i2c", "read", "0x50", "0x10", "3", "--port", uno.port)
    assert code == 0 and "01 02 03" in out


async def test_set_id_verifies_after_reset(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, out = await run("set-id", "--port", uno.port, "0x0002")
    assert code == 0 and "verified" in out
    assert await uno.eeprom(0, 2) == b"\x00\x02"


async def test_errors_are_one_line_and_a_nonzero_code(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    code, _ = await run("servo", "--port", uno.port, "D8", "1500")
    assert code == 1
    err = capsys.readouterr().err
    assert "software PWM is available on D2, D3, D4, D5, D6, D7" in err
    assert "Traceback" not in err
    code, _ = await run("servo", "--port", uno.port, "D9", "2500")
    assert code == 1 and "1000-2000" in capsys.readouterr().err
    code, _ = await run("write", "--port", "/dev/does-not-exist", "D2", "1")
    assert code == 1 and "cannot open /dev/does-not-exist" in capsys.readouterr().err
    code, _ = await run("flash", "--port", uno.port, "--hex", str(tmp_path / "missing.hex"))
    assert code == 2 and "does not exist" in capsys.readouterr().err


# ---- the CLI as a bench tool -------------------------------------------------------------


@pytest.fixture
def no_default_ports(monkeypatch: pytest.MonkeyPatch) -> None:
    """Only the ports a test names are candidates (no USB devices, no ARDUINOIO_PORTS)."""
    monkeypatch.delenv(manager.ENV_PORTS, raising=False)
    monkeypatch.setattr(manager, "_usb_ports", list)


async def test_port_and_id_are_optional_when_one_board_answers(
    virtual_uno_factory: VirtualUnoFactory, no_default_ports: None
) -> None:
    uno = await virtual_uno_factory(board_id=4)
    await uno.drive("D5", 1)
    code, out = await run("read", "D5", "--ports", uno.port)
    assert code == 0 and "D5: level 1" in out


async def test_several_boards_make_an_error_that_lists_them(
    virtual_uno_factory: VirtualUnoFactory,
    no_default_ports: None,
    capsys: pytest.CaptureFixture[str],
) -> None:
    one = await virtual_uno_factory(board_id=1)
    two = await virtual_uno_factory(board_id=2)
    code, _ = await run("info", "--ports", one.port, "--ports", two.port)
    assert code == 1
    err = capsys.readouterr().err
    assert f"0x0001 on {one.port}" in err and f"0x0002 on {two.port}" in err
    assert "--id or --port" in err


async def test_no_candidate_ports_fail_at_once_with_the_hint(
    no_default_ports: None, capsys: pytest.CaptureFixture[str]
) -> None:
    for command in (["list"], ["info"], ["read", "D3"]):
        code, _ = await run(*command)
        assert code == 1
        err = capsys.readouterr().err
        assert "no candidate ports" in err and "--ports" in err and "ARDUINOIO_PORTS" in err
    with anyio.fail_after(2):  # a guard against the old 6.6 s wait, not a measurement
        async with BoardManager() as boards:
            with pytest.raises(BoardNotFoundError, match="no candidate ports"):
                await boards.get(1)


async def test_list_exits_nonzero_when_no_board_answers(
    no_default_ports: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out = await run("list", "--ports", str(tmp_path / "ttyNothing"))
    assert code == 1
    assert "ttyNothing" in out and "no board answered" in capsys.readouterr().err


async def test_list_skips_busy_ports_and_says_so(
    virtual_uno_factory: VirtualUnoFactory, no_default_ports: None
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    other_program = serial.Serial(uno.port, exclusive=True)
    try:
        code, out = await run("list", "--json", "--ports", uno.port)
    finally:
        other_program.close()
    assert code == 1
    (row,) = json.loads(out)
    assert row["port"] == uno.port and "in use by another process" in row["status"]
    code, out = await run("list", "--ports", uno.port)
    assert code == 0 and "0x0001" in out


async def test_set_id_refuses_an_id_that_another_board_has(
    virtual_uno_factory: VirtualUnoFactory,
    no_default_ports: None,
    capsys: pytest.CaptureFixture[str],
) -> None:
    one = await virtual_uno_factory(board_id=1)
    two = await virtual_uno_factory(board_id=2)
    code, _ = await run("set-id", "--port", one.port, "2", "--ports", two.port)
    assert code == 1
    assert f"already used by the board on {two.port}" in capsys.readouterr().err
    assert await one.eeprom(0, 2) == b"\x00\x01"  # nothing was written
    code, out = await run("set-id", "--port", one.port, "2", "--ports", two.port, "--force")
    assert code == 0 and "0x0001 -> 0x0002" in out


async def test_a_busy_pin_is_explained_and_freed_from_the_cli(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    assert (await run("read", "--port", uno.port, "D3"))[0] == 0
    code, _ = await run("servo", "--port", uno.port, "D3", "1500")  # D3: software PWM
    assert code == 1
    err = capsys.readouterr().err
    assert "board refused to make D3 a software PWM output (1500 us pulses): the pin is busy" in err
    assert "D3 already has another role on the board" in err
    assert "on the board D3 is a digital input" in err  # asked the board, not guessed
    assert "arduinoio release D3" in err and "arduinoio reset" in err
    assert "<DigitalPin" not in err and "DigitalPin." not in err
    assert (await run("release", "--port", uno.port, "D3"))[0] == 0
    assert (await run("servo", "--port", uno.port, "D3", "1500"))[0] == 0
    assert (await run("read", "--port", uno.port, "D3"))[0] == 1  # busy again
    capsys.readouterr()
    code, out = await run("servo", "--port", uno.port, "D9", "1200")
    assert code == 0
    code, out = await run("status", "--port", uno.port, "--json")
    assert code == 0 and json.loads(out)["pins"] == {"D3": "software PWM", "D9": "servo PWM"}
    code, out = await run("status", "--port", uno.port)
    assert "pin roles: D3 software PWM, D9 servo PWM" in out
    code, out = await run("reset", "--port", uno.port)
    assert code == 0 and "pins released" in out
    code, out = await run("status", "--port", uno.port, "--json")
    assert code == 0 and json.loads(out)["pins"] == {}
    assert (await run("read", "--port", uno.port, "D3"))[0] == 0


async def test_status_shows_a_tripped_failsafe_and_the_cli_clears_it(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    async with Board.open(uno.port) as board:
        led = await board.digital_output(D4, initial=True)
        await board.arm_failsafe(100, {led: False})
    with anyio.fail_after(5):  # the host went silent: the board applies the safe state
        while (await uno.pin("D4")).level:  # noqa: ASYNC110 - state of the simulated circuit
            await anyio.sleep(0.01)
    code, out = await run("status", "--port", uno.port, "--json")
    assert code == 0 and json.loads(out)["failsafe"] == "tripped"
    code, out = await run("info", "--port", uno.port)
    assert code == 0 and "TRIPPED" in out and "failsafe --clear" in out
    code, _ = await run("write", "--port", uno.port, "D4", "1")
    assert code == 1  # outputs refused while tripped
    code, out = await run("failsafe", "--port", uno.port, "--clear")
    assert code == 0 and "was tripped; now off" in out
    code, out = await run("status", "--port", uno.port)
    assert code == 0 and "failsafe: off" in out
    assert (await run("write", "--port", uno.port, "D4", "1"))[0] == 0


async def test_tables_are_plain_when_piped_and_json_on_request(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    code, out = await run("list", "--ports", uno.port)
    assert code == 0
    header, row = out.splitlines()[:2]
    columns = ["port", "board", "ID", "firmware", "protocol", "baud", "status"]
    assert header.split() == [*columns, "USB", "bridge"]
    assert row.split()[:2] == [uno.port, "0x0001"]
    assert not set("│┃━─") & set(out)
    code, out = await run("info", "--port", uno.port, "--json")
    info = json.loads(out)
    assert (
        code == 0
        and info["id"] == 1
        and info["failsafe"] == "off"
        and info["baud"] == p.DEFAULT_BAUD
    )


async def test_a_stream_the_link_cannot_carry_names_the_shortest_period(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1, baud=p.PAPER_BAUD)
    async with Board.open(uno.port, baudrate=p.PAPER_BAUD) as board:
        channels = [A0, A1, A2, A3]
        with pytest.raises(LinkCapacityError) as refused:
            async with board.stream(analog=channels, period_ms=1):
                pass
        shortest = refused.value.min_period_us
        assert shortest is not None and shortest > 1000
        assert f"at 115200 baud is {shortest / 1000:g} ms" in str(refused.value)
        async with board.stream(analog=channels, period_ms=shortest / 1000) as samples:
            async for _ in samples:  # the named period is admitted
                break


async def test_status_shows_whether_the_board_was_reset_since_a_program_tagged_it(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0061)
    code, out = await run("status", "--port", uno.port, "--json")
    first = json.loads(out)
    assert code == 0 and first["session_found"] == 0  # fresh boot
    code, out = await run("status", "--port", uno.port, "--json")
    assert json.loads(out)["session_found"] == first["session"] != 0  # the first run's tag
    code, out = await run("status", "--port", uno.port)
    assert "tagged by an earlier program, no reset since" in out
    await uno.reset()  # the reset button: nobody tags the new boot
    code, out = await run("status", "--port", uno.port)
    assert "a fresh boot, no program had tagged it" in out


@contextmanager
def board_that_fails_its_handshake(how: str) -> Iterator[str]:
    """A pty that answers the ID probe as board 0x0007, then at the capabilities request
    either hangs up (``"hangup"``) or claims a protocol version this library does not speak
    (``"version"``); or hangs up at the ID probe itself (``"hangup-probe"``)."""
    master, slave = os.openpty()
    path = os.ttyname(slave)
    os.close(slave)
    stop = threading.Event()
    read_id, read_caps = p.ReadId().encode(), p.ReadCapabilities().encode()
    caps = p.ReadCapabilitiesReply(p.PROTOCOL_VERSION + 1, 9, 9, 0, p.DEFAULT_BAUD, 64)

    def answer() -> None:
        received = b""
        while not stop.is_set():
            if not select.select([master], [], [], 0.02)[0]:
                continue
            try:
                received += os.read(master, 256)
            except OSError:
                continue  # nobody has the slave open right now
            if how == "hangup-probe" and read_id in received:
                os.close(master)
                return
            while read_id in received:
                received = received.replace(read_id, b"", 1)
                os.write(master, p.ReadIdReply(7).encode())
            if read_caps in received:
                if how == "hangup":
                    os.close(master)
                    return
                received = received.replace(read_caps, b"", 1)
                os.write(master, caps.encode())

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    try:
        yield path
    finally:
        stop.set()
        thread.join()
        if not how.startswith("hangup"):
            os.close(master)


@pytest.mark.parametrize(
    ("how", "reason"),
    [("hangup", "lost"), ("version", f"speaks protocol version {p.PROTOCOL_VERSION + 1}")],
)
async def test_list_shows_a_board_whose_handshake_failed_with_the_reason(
    no_default_ports: None, how: str, reason: str
) -> None:
    with board_that_fails_its_handshake(how) as port:
        code, out = await run("list", "--json", "--probe-timeout", "2", "--ports", port)
    assert code == 1  # no usable board
    (row,) = json.loads(out)
    assert row["port"] == port and row["id"] == 7
    assert reason in row["status"], row


@pytest.mark.parametrize(
    ("option", "value"),
    [("--baud", "0"), ("--baud", "-9600"), ("--probe-timeout", "-1"), ("--probe-timeout", "nan")],
)
def test_scan_options_refuse_impossible_values(
    option: str, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["list", option, value, "--ports", "/dev/null"], console=Console(file=io.StringIO()))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert option in err and value in err and "must be" in err


async def test_list_survives_a_port_that_hangs_up_during_the_probe(
    virtual_uno_factory: VirtualUnoFactory, no_default_ports: None
) -> None:
    uno = await virtual_uno_factory(board_id=3)
    with board_that_fails_its_handshake("hangup-probe") as port:
        code, out = await run(
            "list", "--json", "--probe-timeout", "2", "--ports", port, "--ports", uno.port
        )
    assert code == 0
    rows = {row["port"]: row for row in json.loads(out)}
    assert rows[uno.port]["status"] == "ok" and rows[uno.port]["id"] == 3
    assert "lost" in rows[port]["status"], rows[port]
