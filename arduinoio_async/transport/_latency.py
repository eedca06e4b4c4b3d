"""Set the fastest safe link for the USB bridge a port sits behind, when it is opened.

Only FTDI bridges have something to set: Linux's ``ftdi_sio`` holds board-to-host bytes
for the chip's *latency timer* (16 ms by default) unless a 62-byte packet fills, so every
round trip to a board behind an FT232R would take ~16 ms.  The timer goes down to 1 ms two
ways, tried in this order:

1. ``/sys/bus/usb-serial/devices/<ttyUSBn>/latency_timer``: write ``1`` (root-owned unless
   a udev rule or ``chmod`` opened it up);
2. the serial driver's low-latency flag: ``TIOCSSERIAL`` with ``ASYNC_LOW_LATENCY``, a flag
   any user who can open the port may set (it is in the kernel's ``ASYNC_USR_MASK``), which
   ``ftdi_sio`` turns into a 1 ms latency timer (``write_latency_timer``: ``if
   (priv->flags & ASYNC_LOW_LATENCY) l = 1``).

When neither works the library warns once per port with the command that fixes it.  The
16U2, CH340 and CP210x have nothing to set here (the 16U2's tick is the board's
low-latency mode, ``Board.choose_low_latency``).  Which bridge a port is on comes from
sysfs (the tty's USB device's ``idVendor``/``idProduct``): a pseudo-terminal -- the
virtual Uno -- or a network URL has no USB device, so nothing happens for it.

The boundaries with the kernel are injectable for tests: :data:`SYSFS_ROOT` (a fake tree
under ``tmp_path``), :data:`sysfs_write` (a root-owned file refuses the write) and
:data:`serial_ioctl`; :func:`tune_link` also takes them as arguments.
"""

from __future__ import annotations

import array
import logging
import os
import threading
from collections.abc import Callable
from dataclasses import dataclass

from ._bridges import Bridge, boot_quiet_for_ids, bridge_for_ids

__all__ = ["SYSFS_ROOT", "LinkTuning", "last_tuning", "port_bridge", "tune_link"]

logger = logging.getLogger(__name__)

#: Where sysfs is mounted; tests point it at a fake tree.
SYSFS_ROOT = "/sys"

#: linux/serial.h and asm-generic/ioctls.h (the same on every Linux architecture
#: pyserial supports); pyserial's ``set_low_latency_mode`` uses the same numbers.
TIOCGSERIAL = 0x541E
TIOCSSERIAL = 0x541F
ASYNC_LOW_LATENCY = 1 << 13
#: ``struct serial_struct`` as ints; ``flags`` is its fifth int.
_SERIAL_STRUCT_INTS = 32
_FLAGS_INDEX = 4

#: ioctl(fd, request, buffer): fills or reads ``buffer`` in place, raises OSError.
IoctlFn = Callable[[int, int, "array.array[int]"], None]


def _system_ioctl(fd: int, request: int, buf: array.array[int]) -> None:
    import fcntl  # POSIX only: imported where it is used

    fcntl.ioctl(fd, request, buf, True)


def _system_write(path: str, text: str) -> None:
    with open(path, "w", encoding="ascii") as f:
        f.write(text)


#: The kernel boundaries :func:`tune_link` uses unless given others (tests replace them).
serial_ioctl: IoctlFn = _system_ioctl
sysfs_write: Callable[[str, str], None] = _system_write


@dataclass(frozen=True, slots=True)
class LinkTuning:
    """What opening ``port`` found and set."""

    port: str
    #: The bridge the port is on, None for no USB device (a pty, a URL) or an unknown one.
    bridge: Bridge | None
    #: What was set, in words ("" when nothing needed setting).
    applied: str = ""
    #: Why the fastest link could not be set, with the command that fixes it ("" if none).
    problem: str = ""


_last: dict[str, LinkTuning] = {}
_warned: set[str] = set()
#: The manager opens ports concurrently, each in its own worker thread.
_lock = threading.Lock()


def last_tuning(port: str) -> LinkTuning | None:
    """What the last open of ``port`` in this process found and set (for ``arduinoio
    info``), None if it was never opened."""
    return _last.get(port)


def _tty_name(port: str) -> str:
    return os.path.basename(os.path.realpath(port))


def _read_id(path: str) -> int | None:
    try:
        with open(path, encoding="ascii") as f:
            return int(f.read().strip(), 16)
    except (OSError, ValueError):
        return None


def port_usb_ids(port: str, sysfs_root: str | None = None) -> tuple[int, int | None] | None:
    """(vendor, product) of the USB device ``port`` belongs to, from sysfs; None when it
    has none (pty, URL, on-board UART).  Blocking (sysfs)."""
    root = SYSFS_ROOT if sysfs_root is None else sysfs_root
    device = os.path.join(root, "class", "tty", _tty_name(port), "device")
    if not os.path.exists(device):
        return None
    path = os.path.realpath(device)
    # The tty's device is the USB interface (cdc_acm) or a port below it (usb-serial):
    # the USB device with the IDs is one or two levels up.
    for _ in range(3):
        vid = _read_id(os.path.join(path, "idVendor"))
        if vid is not None:
            return vid, _read_id(os.path.join(path, "idProduct"))
        path = os.path.dirname(path)
    return None


def port_bridge(port: str, sysfs_root: str | None = None) -> Bridge | None:
    """The bridge ``port`` sits behind, from its USB device's IDs in sysfs; None when it
    has no USB device (pty, URL, on-board UART) or an unknown one.  Blocking (sysfs)."""
    ids = port_usb_ids(port, sysfs_root)
    return bridge_for_ids(*ids) if ids is not None else None


def port_boot_quiet(port: str, sysfs_root: str | None = None) -> float:
    """Seconds to keep quiet after opening ``port`` (a Mega's bootloader window,
    ``_bridges.BOOT_QUIET_S``); 0 for every other port.  Blocking (sysfs)."""
    ids = port_usb_ids(port, sysfs_root)
    return boot_quiet_for_ids(*ids) if ids is not None else 0.0


def _set_low_latency_flag(fd: int, ioctl: IoctlFn) -> str:
    """Set ASYNC_LOW_LATENCY on ``fd``; "" when it stuck, else why not."""
    buf = array.array("i", [0] * _SERIAL_STRUCT_INTS)
    try:
        ioctl(fd, TIOCGSERIAL, buf)
        buf[_FLAGS_INDEX] |= ASYNC_LOW_LATENCY
        ioctl(fd, TIOCSSERIAL, buf)
        check = array.array("i", [0] * _SERIAL_STRUCT_INTS)
        ioctl(fd, TIOCGSERIAL, check)
    except OSError as exc:
        return exc.strerror or str(exc)
    if not check[_FLAGS_INDEX] & ASYNC_LOW_LATENCY:
        return "the driver did not keep the flag"
    return ""


def _tune_ftdi(
    port: str, fd: int | None, root: str, ioctl: IoctlFn, write: Callable[[str, str], None]
) -> tuple[str, str]:
    name = _tty_name(port)
    path = os.path.join(root, "bus", "usb-serial", "devices", name, "latency_timer")
    try:
        with open(path, encoding="ascii") as f:
            current = f.read().strip()
    except OSError:
        current = "?"
    if current == "1":
        return "latency timer already 1 ms", ""
    try:
        write(path, "1")
        return f"latency timer {current} -> 1 ms ({path})", ""
    except OSError as exc:
        sysfs_error = exc.strerror or str(exc)
    flag_error = "no file descriptor" if fd is None else _set_low_latency_flag(fd, ioctl)
    if not flag_error:
        return f"latency timer {current} -> 1 ms (serial driver's low-latency flag)", ""
    held = f"{current} ms" if current.isdigit() else "16 ms (the default)"
    return "", (
        f"{port}: its FTDI bridge holds every reply for its latency timer ({held}): "
        f"writing {path} failed ({sysfs_error}) and the serial driver's low-latency flag "
        f"failed ({flag_error}). Fix: `echo 1 | sudo tee {path}` (until replugged), or "
        "for good a udev rule in /etc/udev/rules.d/99-ftdi-latency.rules: "
        'ACTION=="add", SUBSYSTEM=="usb-serial", DRIVER=="ftdi_sio", '
        'ATTR{latency_timer}="1"'
    )


def tune_link(
    port: str,
    fd: int | None,
    *,
    sysfs_root: str | None = None,
    ioctl: IoctlFn | None = None,
    write: Callable[[str, str], None] | None = None,
) -> LinkTuning:
    """Set the fastest safe link for ``port``'s bridge (``fd``: its open descriptor).

    Blocking (sysfs, ioctl): the caller runs it in a worker thread.  Never raises for
    what it cannot set: it logs a warning once per port (the fix included) and reports
    it in :attr:`LinkTuning.problem`.
    """
    root = SYSFS_ROOT if sysfs_root is None else sysfs_root
    bridge = port_bridge(port, root)
    applied = problem = ""
    if bridge is not None and bridge.latency_timer:
        applied, problem = _tune_ftdi(port, fd, root, ioctl or serial_ioctl, write or sysfs_write)
    tuning = LinkTuning(port, bridge, applied, problem)
    with _lock:
        _last[port] = tuning
        first = port not in _warned
        if problem:
            _warned.add(port)
    if problem:
        if first:
            logger.warning("%s", problem)
    elif bridge is not None:
        logger.debug("%s: %s bridge: %s", port, bridge.kind, applied or "nothing to set")
    return tuning
