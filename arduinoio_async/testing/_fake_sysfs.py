"""A fake sysfs tree with USB-serial ports, for testing what the library sets on a bridge.

The library reads a port's USB IDs and an FTDI's ``latency_timer`` from sysfs
(``arduinoio_async.transport._latency``).  :class:`FakeSysfs` lays out the few files it
reads -- under a temporary directory instead of ``/sys`` -- as Linux does:

- ``class/tty/<name>/device``: a link to the USB interface (``cdc_acm``: 16U2, CH9102)
  or to the ``usb-serial`` port below it (``ftdi_sio``, ``ch341``, ``cp210x``);
- the USB device's ``idVendor``/``idProduct`` one level above the interface;
- ``bus/usb-serial/devices/<name>`` for usb-serial ports, with ``latency_timer`` (16)
  on FTDI ports only.

Point the library at it with ``monkeypatch.setattr(_latency, "SYSFS_ROOT", str(root))``.
``<name>`` is the port's device node name: ``ttyUSB0`` for ``/dev/ttyUSB0``, or the
virtual Uno's pseudo-terminal number (``7`` for ``/dev/pts/7``) when a test makes the
virtual Uno's port look like a USB device (then the harness's FTDI model gets the value
the library wrote through ``VirtualUno.set_latency_timer``).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["FakeSysfs"]

#: Which kernel driver serves which vendor: usb-serial ones have a port directory.
_USB_SERIAL_VENDORS = {0x0403: "ftdi_sio", 0x1A86: "ch341", 0x10C4: "cp210x"}
_CDC_ACM = {(0x1A86, 0x55D4)}  # the CH9102 is a CDC ACM device despite WCH's vendor ID


class FakeSysfs:
    """A sysfs root under ``root`` to which USB-serial ports are added."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self._next_device = 1

    def add_port(self, name: str, vid: int, pid: int) -> Path:
        """Add tty ``name`` behind the USB device ``vid:pid``; returns its sysfs port
        directory (the ``usb-serial`` port, or the interface for ``cdc_acm``)."""
        device = self.root / "devices" / "pci0000:00" / "usb1" / f"1-{self._next_device}"
        self._next_device += 1
        interface = device / f"{device.name}:1.0"
        interface.mkdir(parents=True)
        (device / "idVendor").write_text(f"{vid:04x}\n")
        (device / "idProduct").write_text(f"{pid:04x}\n")
        driver = _USB_SERIAL_VENDORS.get(vid)
        if driver is None or (vid, pid) in _CDC_ACM:
            target = interface  # cdc_acm: the tty's device is the interface
        else:
            target = interface / name
            target.mkdir()
            (target / "driver_name").write_text(driver + "\n")
            if driver == "ftdi_sio":
                (target / "latency_timer").write_text("16\n")
            bus = self.root / "bus" / "usb-serial" / "devices"
            bus.mkdir(parents=True, exist_ok=True)
            os.symlink(target, bus / name)
        tty = self.root / "class" / "tty" / name
        tty.mkdir(parents=True)
        os.symlink(target, tty / "device")
        return target

    def add_device_of(self, port: str, vid: int, pid: int) -> str:
        """Describe the tty ``port`` resolves to (a pty too) as behind ``vid:pid``; returns
        its name, the key the library looks it up by.  Blocking: from async code, run it
        in a worker thread."""
        name = os.path.basename(os.path.realpath(port))
        self.add_port(name, vid, pid)
        return name

    def latency_timer(self, name: str) -> int | None:
        """The ``latency_timer`` of port ``name`` (None when it has none)."""
        path = self.root / "bus" / "usb-serial" / "devices" / name / "latency_timer"
        try:
            return int(path.read_text().strip())
        except FileNotFoundError:
            return None
