"""A Mega 2560 known by its USB IDs: the open waits out its bootloader's window, and
`arduinoio flash` picks its image and bootloader protocol (issue 29).

Opening the port resets a Mega (DTR) into Arduino's stk500v2 bootloader, which takes any
byte of its first 0.84 s (measured on the virtual Mega running it) for a programmer's and
then stays in programming mode until seconds of silence: the library's ready probes would
trap it.  Behind a Mega's USB IDs the library sends nothing for ``BOOT_QUIET_S`` after the
open.  The oracle is the other end of a pseudo-terminal described as the board's tty in a
fake sysfs: when its first byte arrives.  (On the virtual Mega the same wait is wall-clock
time, which a loaded machine's simulation may not keep up with, so the end-to-end check
is not a test: notes/w4-mega.md.)
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import anyio
import pytest

from arduinoio_async.board import Board
from arduinoio_async.errors import BoardSilentError
from arduinoio_async.testing._fake_sysfs import FakeSysfs
from arduinoio_async.transport import _latency
from arduinoio_async.transport._bridges import BOOT_QUIET_S, boot_quiet_for_ids
from tests.e2e.test_cli import run


def test_only_the_megas_usb_ids_ask_for_quiet() -> None:
    assert boot_quiet_for_ids(0x2341, 0x0042) == BOOT_QUIET_S[(0x2341, 0x0042)] >= 1.0
    assert boot_quiet_for_ids(0x2341, 0x0010) >= 1.0  # the first Mega 2560 (8U2)
    assert boot_quiet_for_ids(0x2341, 0x0043) == 0.0  # Uno R3: optiboot leaves at a byte
    assert boot_quiet_for_ids(0x1A86, 0x7523) == 0.0  # CH340
    assert boot_quiet_for_ids(None, None) == 0.0


@pytest.mark.parametrize(("pid", "quiet"), [(0x0042, True), (0x0043, False)])
async def test_the_first_probe_waits_out_a_megas_boot_window(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, pid: int, quiet: bool
) -> None:
    master, slave = os.openpty()
    try:
        port = os.ttyname(slave)
        sysfs = FakeSysfs(tmp_path / "sys")
        await anyio.to_thread.run_sync(sysfs.add_device_of, port, 0x2341, pid)
        monkeypatch.setattr(_latency, "SYSFS_ROOT", str(sysfs.root))
        os.set_blocking(master, False)
        first_byte_after: list[float] = []

        async def watch_line(start: float) -> None:
            while not first_byte_after:
                await anyio.wait_readable(master)
                if os.read(master, 64):
                    first_byte_after.append(time.monotonic() - start)

        async with anyio.create_task_group() as tg:
            tg.start_soon(watch_line, time.monotonic())
            with pytest.raises(BoardSilentError):  # nobody answers on this line
                async with Board.open(port, baudrate=115200, ready_timeout=0.3):
                    pass
            tg.cancel_scope.cancel()
        wait = BOOT_QUIET_S[(0x2341, 0x0042)]
        assert first_byte_after, "the library never probed"
        assert (first_byte_after[0] >= wait) is quiet, first_byte_after
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize(
    ("pid", "expected"),
    [(0x0042, "-p atmega2560 -c wiring"), (0x0043, "-p atmega328p -c arduino")],
)
async def test_flash_picks_the_image_and_bootloader_of_the_board_it_finds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, pid: int, expected: str
) -> None:
    """Without --board, the port's USB IDs choose: a Mega's gets its image and stk500v2."""
    master, slave = os.openpty()
    try:
        port = os.ttyname(slave)
        sysfs = FakeSysfs(tmp_path / "sys")
        await anyio.to_thread.run_sync(sysfs.add_device_of, port, 0x2341, pid)
        monkeypatch.setattr(_latency, "SYSFS_ROOT", str(sysfs.root))
        code, out = await run("flash", "--port", port, "--firmware-baud", "115200", "--dry-run")
        assert code == 0, out
        assert expected in out
        mega = pid == 0x0042
        assert ("arduinoio-mega2560-115200.hex" in out) is mega, out
    finally:
        os.close(master)
        os.close(slave)
