"""USB bridges (issue 29 item 4): recognition by USB ID, and what opening a port sets on
each bridge, against a fake sysfs tree (``arduinoio_async.testing._fake_sysfs``) and a
fake ``TIOCGSERIAL``/``TIOCSSERIAL`` that behaves as Linux's ``ftdi_sio`` does.

The virtual Uno counterpart (the FTDI and CH340 models' timing, the library's setting
reaching the FTDI model) is ``tests/e2e/test_bridges.py``.
"""

from __future__ import annotations

import array
import errno
import logging
import os
import threading
from pathlib import Path

import anyio
import pytest

from arduinoio_async import manager
from arduinoio_async.testing._fake_sysfs import FakeSysfs
from arduinoio_async.transport import (
    BRIDGES,
    TICK_HOLDING_BRIDGES,
    _latency,
    _serial,
    bridge_for_ids,
    last_tuning,
    open_serial_stream,
    port_bridge,
    tune_link,
)

FTDI = (0x0403, 0x6001)
FT231X = (0x0403, 0x6015)
CH340 = (0x1A86, 0x7523)
CH9102 = (0x1A86, 0x55D4)
CP2102 = (0x10C4, 0xEA60)
UNO_R3 = (0x2341, 0x0043)


class FtdiSioIoctl:
    """``TIOCGSERIAL``/``TIOCSSERIAL`` as ``ftdi_sio`` answers them for an unprivileged
    user: the flags in ``ASYNC_USR_MASK`` (``ASYNC_LOW_LATENCY`` among them) are kept."""

    def __init__(self, fail: int | None = None) -> None:
        self.flags = 0
        self.fail = fail
        self.calls: list[int] = []

    def __call__(self, fd: int, request: int, buf: array.array[int]) -> None:
        self.calls.append(request)
        if self.fail is not None:
            raise OSError(self.fail, os.strerror(self.fail))
        if request == _latency.TIOCGSERIAL:
            buf[_latency._FLAGS_INDEX] = self.flags
        elif request == _latency.TIOCSSERIAL:
            self.flags = buf[_latency._FLAGS_INDEX]


def refuse(path: str, text: str) -> None:
    """sysfs as a user who may not write the root-owned latency_timer sees it."""
    raise PermissionError(errno.EACCES, "Permission denied", path)


def never(path: str, text: str) -> None:
    raise AssertionError(f"nothing should be written, wrote {text!r} to {path}")


@pytest.fixture
def sysfs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> FakeSysfs:
    monkeypatch.setattr(_latency, "SYSFS_ROOT", str(tmp_path / "sys"))
    monkeypatch.setattr(_latency, "_warned", set())
    return FakeSysfs(tmp_path / "sys")


# ---- recognition ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("ids", "kind"),
    [
        ((0x2341, 0x0001), "16u2"),  # Uno (8U2)
        (UNO_R3, "16u2"),
        ((0x2341, 0x0243), "16u2"),
        ((0x2341, 0x0042), "16u2"),  # Mega 2560 R3
        ((0x2A03, 0x0043), "16u2"),
        (FTDI, "ftdi"),
        (FT231X, "ftdi"),
        ((0x0403, 0x6014), "ftdi"),  # FT232H: the vendor-wide entry
        (CH340, "ch340"),
        ((0x1A86, 0x5523), "ch340"),  # CH341
        (CH9102, "ch340"),
        (CP2102, "cp210x"),
        ((0x10C4, 0xEA70), "cp210x"),
    ],
)
def test_bridges_are_recognised_by_usb_id(ids: tuple[int, int], kind: str) -> None:
    bridge = bridge_for_ids(*ids)
    assert bridge is not None and bridge.kind == kind


@pytest.mark.parametrize(
    "ids", [(0x067B, 0x2303), (0x2341, 0x8036), (0x1A86, 0x0001), (None, None)]
)
def test_other_devices_are_no_bridge(ids: tuple[int | None, int | None]) -> None:
    """A Prolific adapter, a Leonardo's native USB, another WCH product, no USB at all."""
    assert bridge_for_ids(*ids) is None


def test_every_bridge_says_its_behaviour_and_rates_and_only_ftdi_has_a_timer() -> None:
    assert {b.kind for b in BRIDGES} == {"16u2", "ftdi", "ch340", "cp210x"}
    for bridge in BRIDGES:
        assert bridge.name and bridge.behaviour and bridge.baud_rates and bridge.ids
        assert bridge.latency_timer == (bridge.kind == "ftdi")
        assert bridge.tick_holding == (bridge.kind == "16u2")
    ch340 = bridge_for_ids(*CH340)
    assert ch340 is not None and "2 Mbaud" in ch340.baud_rates


def test_discovery_still_probes_every_id_it_probed_before() -> None:
    """``manager.USB_IDS`` (public) is now derived from the table; nothing dropped out."""
    before = {
        (0x2341, None),
        (0x2A03, None),
        (0x1A86, 0x7523),
        (0x1A86, 0x55D4),
        (0x0403, None),
        (0x10C4, 0xEA60),
        (0x03EB, 0x2FEF),
    }
    assert before <= set(manager.USB_IDS)
    assert TICK_HOLDING_BRIDGES[UNO_R3] == bridge_for_ids(*UNO_R3).name  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("name", "ids", "kind"),
    [
        ("ttyUSB0", FTDI, "ftdi"),
        ("ttyUSB1", CH340, "ch340"),
        ("ttyACM1", CH9102, "ch340"),  # cdc_acm: the tty's device is the interface
        ("ttyUSB2", CP2102, "cp210x"),
        ("ttyACM0", UNO_R3, "16u2"),
    ],
)
def test_a_ports_bridge_is_read_from_sysfs(
    sysfs: FakeSysfs, tmp_path: Path, name: str, ids: tuple[int, int], kind: str
) -> None:
    sysfs.add_port(name, *ids)
    bridge = port_bridge(f"/dev/{name}")
    assert bridge is not None and bridge.kind == kind
    link = tmp_path / "usb-by-id-if00"  # /dev/serial/by-id names resolve to the tty
    link.symlink_to(f"/dev/{name}")
    assert port_bridge(str(link)) is bridge


def test_a_pty_a_url_and_an_onboard_uart_have_no_bridge(sysfs: FakeSysfs) -> None:
    (sysfs.root / "class" / "tty" / "ttyS0").mkdir(parents=True)  # no device link
    for port in ("/dev/pts/3", "socket://localhost:5000", "/dev/ttyS0", "/dev/ttyUSB9"):
        assert port_bridge(port) is None


# ---- what opening a port sets ------------------------------------------------------------


def test_ftdi_gets_a_1_ms_latency_timer_through_sysfs(sysfs: FakeSysfs) -> None:
    sysfs.add_port("ttyUSB0", *FTDI)
    ioctl = FtdiSioIoctl()
    tuning = tune_link("/dev/ttyUSB0", 5, ioctl=ioctl)
    assert sysfs.latency_timer("ttyUSB0") == 1
    assert tuning.bridge is not None and tuning.bridge.kind == "ftdi"
    assert "16 -> 1 ms" in tuning.applied and not tuning.problem
    assert ioctl.calls == []  # sysfs sufficed


@pytest.mark.parametrize(("name", "ids"), [("ttyUSB1", CH340), ("ttyUSB2", CP2102)])
def test_ch340_and_cp210x_get_nothing_written(
    sysfs: FakeSysfs, name: str, ids: tuple[int, int]
) -> None:
    port_dir = sysfs.add_port(name, *ids)
    (port_dir / "latency_timer").write_text("16\n")  # even if one were there
    ioctl = FtdiSioIoctl()
    tuning = tune_link(f"/dev/{name}", 5, ioctl=ioctl, write=never)
    assert sysfs.latency_timer(name) == 16 and ioctl.calls == []
    assert tuning.bridge is not None and not tuning.applied and not tuning.problem


def test_the_16u2_gets_nothing_written(sysfs: FakeSysfs) -> None:
    sysfs.add_port("ttyACM0", *UNO_R3)
    ioctl = FtdiSioIoctl()
    tuning = tune_link("/dev/ttyACM0", 5, ioctl=ioctl, write=never)
    assert ioctl.calls == [] and not tuning.applied and not tuning.problem


def test_an_ftdi_already_at_1_ms_is_left_alone(sysfs: FakeSysfs) -> None:
    port_dir = sysfs.add_port("ttyUSB0", *FTDI)
    (port_dir / "latency_timer").write_text("1\n")
    tuning = tune_link("/dev/ttyUSB0", 5, ioctl=FtdiSioIoctl(), write=never)
    assert "already 1 ms" in tuning.applied


def test_read_only_sysfs_falls_back_to_the_low_latency_flag(
    sysfs: FakeSysfs, caplog: pytest.LogCaptureFixture
) -> None:
    sysfs.add_port("ttyUSB0", *FTDI)
    ioctl = FtdiSioIoctl()
    with caplog.at_level(logging.WARNING, logger=_latency.__name__):
        tuning = tune_link("/dev/ttyUSB0", 5, ioctl=ioctl, write=refuse)
    assert ioctl.flags & _latency.ASYNC_LOW_LATENCY  # the driver now runs the timer at 1 ms
    assert _latency.TIOCSSERIAL in ioctl.calls
    assert "low-latency flag" in tuning.applied and not tuning.problem
    assert not caplog.records


def test_when_nothing_works_one_warning_says_the_fix(
    sysfs: FakeSysfs, caplog: pytest.LogCaptureFixture
) -> None:
    sysfs.add_port("ttyUSB0", *FTDI)
    path = sysfs.root / "bus" / "usb-serial" / "devices" / "ttyUSB0" / "latency_timer"
    with caplog.at_level(logging.WARNING, logger=_latency.__name__):
        first = tune_link("/dev/ttyUSB0", 5, ioctl=FtdiSioIoctl(errno.ENOTTY), write=refuse)
        again = tune_link("/dev/ttyUSB0", 5, ioctl=FtdiSioIoctl(errno.ENOTTY), write=refuse)
    assert sysfs.latency_timer("ttyUSB0") == 16
    assert [r.levelno for r in caplog.records] == [logging.WARNING]  # once per port
    text = caplog.records[0].getMessage()
    assert f"echo 1 | sudo tee {path}" in text
    assert 'ATTR{latency_timer}="1"' in text and "16 ms" in text
    assert "Permission denied" in text
    assert first.problem == again.problem == text and not first.applied
    assert last_tuning("/dev/ttyUSB0") == again


def test_a_driver_that_drops_the_flag_is_not_taken_for_success(sysfs: FakeSysfs) -> None:
    sysfs.add_port("ttyUSB0", *FTDI)

    def forgetful(fd: int, request: int, buf: array.array[int]) -> None:
        buf[_latency._FLAGS_INDEX] = 0  # accepts TIOCSSERIAL, keeps nothing

    tuning = tune_link("/dev/ttyUSB0", 5, ioctl=forgetful, write=refuse)
    assert tuning.problem and "did not keep the flag" in tuning.problem


async def test_opening_a_port_tunes_it_and_a_pty_is_left_alone(
    sysfs: FakeSysfs, pty: tuple[int, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The hook in ``open_serial_stream``: a plain pty has no USB device, nothing
    happens; the same pty described by sysfs as an FTDI's tty gets its timer lowered."""
    _, port = pty
    monkeypatch.setattr(_latency, "sysfs_write", never)
    stream = await open_serial_stream(port)
    await stream.aclose()
    plain = last_tuning(port)
    assert plain is not None and plain.bridge is None and not plain.applied

    monkeypatch.setattr(_latency, "sysfs_write", _latency._system_write)
    name = await anyio.to_thread.run_sync(sysfs.add_device_of, port, *FTDI)
    stream = await open_serial_stream(port)
    await stream.aclose()
    assert await anyio.to_thread.run_sync(sysfs.latency_timer, name) == 1


def test_concurrent_opens_warn_once(sysfs: FakeSysfs, caplog: pytest.LogCaptureFixture) -> None:
    """The manager probes ports from concurrent worker threads."""
    sysfs.add_port("ttyUSB0", *FTDI)

    def tune() -> None:
        tune_link("/dev/ttyUSB0", 5, ioctl=FtdiSioIoctl(errno.ENOTTY), write=refuse)

    with caplog.at_level(logging.WARNING, logger=_latency.__name__):
        threads = [threading.Thread(target=tune) for _ in range(8)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    assert len(caplog.records) == 1


async def test_an_open_cancelled_while_the_link_is_tuned_leaves_the_port_free(
    pty: tuple[int, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Cancelled (a probe's deadline) after pyserial opened and locked the port: the port
    is closed, not leaked, so the next open does not find it busy."""
    _, port = pty
    started = threading.Event()
    release = threading.Event()

    def slow_tune(url: str, fd: int | None) -> None:
        started.set()
        release.wait(5)

    monkeypatch.setattr(_serial, "tune_link", slow_tune)

    async def open_it() -> None:
        await open_serial_stream(port)
        pytest.fail("the open was to be cancelled")

    async with anyio.create_task_group() as tg:
        tg.start_soon(open_it)
        await anyio.to_thread.run_sync(started.wait, 5)
        tg.cancel_scope.cancel()
        release.set()
    monkeypatch.setattr(_serial, "tune_link", tune_link)
    stream = await open_serial_stream(port)  # PortBusyError if the first open leaked
    await stream.aclose()
