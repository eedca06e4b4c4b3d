"""The virtual Uno's FTDI and CH340 bridge models (issue 29 item 4), and the library's FTDI
setting reaching the FTDI model through a fake sysfs.

The models' timing is checked against their documented figures (firmware/sim/README.md,
docs/boards.md) with the harness's own clock: its status reports how long each release
of bytes waited in the model, in simulated time, which the machine's load cannot change.
Host-side round trips are checked only where the model guarantees them: the harness never
delivers a byte before the model's time, so behind a 16 ms latency timer no round trip is
shorter than 16 ms.  The p50 figures are measured by ``benchmarks/boards_bridges.py``.

How the library's setting reaches the model: the test describes the virtual Uno's
pseudo-terminal as an FTDI's tty in a fake sysfs (``FakeSysfs``, ``_latency.SYSFS_ROOT``),
the library writes ``latency_timer`` when it opens the port, and the test hands the value
it wrote to the model (``VirtualUno.set_latency_timer``), as ``ftdi_sio`` hands it to the
chip.
"""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import anyio
import pytest
from rich.console import Console

from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.sim import SimulatorError, VirtualUno
from arduinoio_async.sim.cli import main as sim_main
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory
from arduinoio_async.testing._fake_sysfs import FakeSysfs
from arduinoio_async.transport import _latency

pytestmark = pytest.mark.sim

FRAME_US = 1000.0  # a USB full-speed frame: the models release at the next one


async def run_cli(*argv: str) -> tuple[int, str]:
    """The ``arduinoio`` command in a worker thread (it starts its own event loop)."""
    buffer = io.StringIO()
    console = Console(file=buffer, width=300)
    code = await anyio.to_thread.run_sync(lambda: cli_main(list(argv), console=console))
    return code, buffer.getvalue()


async def round_trips_ms(board: Board, n: int) -> list[float]:
    times = []
    for _ in range(n):
        start = time.monotonic()
        assert await board.read_id() == board.board_id
        times.append((time.monotonic() - start) * 1000.0)
    return times


async def test_the_library_lowers_the_ftdi_models_timer_from_16_to_1_ms(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    uno = await virtual_uno_factory(board_id=0x0029, usb_bridge="ftdi")
    sysfs = FakeSysfs(tmp_path / "sys")
    # the pty, as an FT232R's tty
    name = await anyio.to_thread.run_sync(sysfs.add_device_of, uno.port, 0x0403, 0x6001)
    monkeypatch.setattr(_latency, "SYSFS_ROOT", str(sysfs.root))
    async with Board.open(uno.port) as board:
        written = await anyio.to_thread.run_sync(sysfs.latency_timer, name)
        assert written == 1  # the library's setting, written at open
        # The model still runs the chip's default: every reply waited 16 ms + a frame.
        default = await round_trips_ms(board, 5)
        bridge = (await uno.status())["bridge"]
        assert bridge["model"] == "ftdi" and bridge["latency_ms"] == 16
        assert 16000.0 <= bridge["hold_min_us"] <= bridge["hold_max_us"] <= 16000.0 + FRAME_US
        assert bridge["full_releases"] == 0  # 5-byte replies never fill a 62-byte packet
        assert min(default) >= 16.0  # never delivered before the model's time
        # ftdi_sio sends the chip what was written; the harness's control channel does here
        await uno.set_latency_timer(written)
        lowered = await round_trips_ms(board, 20)
        bridge = (await uno.status())["bridge"]
        assert bridge["latency_ms"] == 1 and bridge["holds"] >= 20
        assert 1000.0 <= bridge["hold_min_us"] <= bridge["hold_max_us"] <= 1000.0 + FRAME_US
        assert sorted(lowered)[len(lowered) // 2] < 16.0  # generous: the 16 ms hold is gone


async def test_the_ftdi_model_sends_a_full_62_byte_packet_without_waiting(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """62 waiting bytes go at once: pipelined replies fill packets before the timer."""
    uno = await virtual_uno_factory(board_id=7, usb_bridge="ftdi", ftdi_latency_ms=255)
    async with Board.open(uno.port) as board:
        await uno.set_latency_timer(255)  # clears the statistics of the open's probes
        async with anyio.create_task_group() as tg:
            for _ in range(40):  # 40 replies of 5 bytes: 200 bytes, three full packets
                tg.start_soon(board.read_id)
        bridge = (await uno.status())["bridge"]
        assert bridge["full_releases"] >= 3
        assert bridge["hold_min_us"] < 255000.0  # a full packet did not wait for the timer


async def test_the_ch340_model_forwards_at_the_next_usb_frame(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0340, usb_bridge="ch340")
    async with Board.open(uno.port) as board:
        await round_trips_ms(board, 10)
        bridge = (await uno.status())["bridge"]
    assert bridge["model"] == "ch340" and bridge["holds"] >= 50  # every byte is counted
    assert 0.0 < bridge["hold_min_us"] <= bridge["hold_max_us"] <= FRAME_US
    assert bridge["timer_releases"] == 0


async def test_bridge_options_are_checked(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    uno = await virtual_uno_factory(board_id=1, usb_bridge="ch340")
    with pytest.raises(SimulatorError, match="needs --usb-bridge ftdi"):
        await uno.set_latency_timer(1)
    ftdi = await virtual_uno_factory(board_id=2, usb_bridge="ftdi", ftdi_latency_ms=4)
    assert (await ftdi.status())["bridge"]["latency_ms"] == 4
    with pytest.raises(SimulatorError, match=r"ms 1\.\.255"):
        await ftdi.set_latency_timer(0)
    with pytest.raises(ValueError, match="unknown usb_bridge"):
        VirtualUno(usb_bridge="pl2303")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ftdi_latency_ms"):
        VirtualUno(usb_bridge="ch340", ftdi_latency_ms=1)
    with pytest.raises(SystemExit) as exited:
        sim_main(["--bridge", "ch340", "--ftdi-latency-ms", "1"])
    assert exited.value.code == 2
    assert "--ftdi-latency-ms needs --usb-bridge ftdi" in capsys.readouterr().err


async def test_info_says_the_bridge_and_the_fix_when_the_timer_stays_at_16_ms(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """sysfs refuses the write (a root-owned file) and the pty refuses TIOCGSERIAL as a
    driver without the flag would: ``arduinoio info`` shows the bridge and the command."""
    uno = await virtual_uno_factory(board_id=0x0031, usb_bridge="ftdi")
    sysfs = FakeSysfs(tmp_path / "sys")
    await anyio.to_thread.run_sync(sysfs.add_device_of, uno.port, 0x0403, 0x6015)
    monkeypatch.setattr(_latency, "SYSFS_ROOT", str(sysfs.root))
    monkeypatch.setattr(_latency, "_warned", set())

    def refuse(path: str, text: str) -> None:
        raise PermissionError(13, "Permission denied", path)

    monkeypatch.setattr(_latency, "sysfs_write", refuse)
    code, out = await run_cli("info", "--json", "--id", "0x31", "--ports", uno.port)
    assert code == 0
    bridge = json.loads(out)["usb_bridge"]
    assert bridge["kind"] == "ftdi" and not bridge["set"]
    assert "echo 1 | sudo tee" in bridge["problem"] and "latency_timer" in bridge["problem"]
    code, out = await run_cli("info", "--id", "0x31", "--ports", uno.port)
    assert code == 0 and "USB bridge" in out and "sudo tee" in out
    code, out = await run_cli("list", "--json", "--ports", uno.port)
    assert code == 0 and "latency timer not lowered" in json.loads(out)[0]["bridge"]
    assert (await uno.status())["bridge"]["latency_ms"] == 16  # nothing reached the chip


async def test_info_on_a_plain_pty_says_there_is_no_usb_bridge(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=0x0032)
    code, out = await run_cli("info", "--json", "--id", "0x32", "--ports", uno.port)
    assert code == 0 and json.loads(out)["usb_bridge"] is None
    code, out = await run_cli("info", "--id", "0x32", "--ports", uno.port)
    assert code == 0 and "no USB device" in out
    code, out = await run_cli("list", "--ports", uno.port)
    assert code == 0 and "0x0032" in out and "None" not in out
