"""The USB-serial bridges boards ship with, known by their USB IDs (issue 29 item 4).

Each bridge moves the board's UART bytes into USB packets by its own rule, and that rule
sets the round trip a host sees (docs/boards.md has the figures and their sources):

- the Uno's and Mega's ATmega16U2/8U2 (``arduino-usbserial``) holds board-to-host bytes
  until its 4.096 ms Timer0 tick or until more than 96 wait (the board's low-latency mode
  pads replies past that, see ``Board.choose_low_latency``);
- FTDI's FT232R/FT231X hold them for the driver's *latency timer* (16 ms on Linux unless
  lowered) or until a 62-byte packet fills: the library lowers it to 1 ms when it opens
  such a port (``transport._latency``);
- WCH's CH340/CH341 (and the CDC-class CH9102) and Silicon Labs' CP210x pass bytes on at
  the next USB poll, with nothing to tune.

The table is data only; :func:`bridge_for_ids` looks an ID pair up and
:data:`DISCOVERY_IDS` is what the manager probes.  A pseudo-terminal or a network URL has
no USB IDs, so nothing here applies to it (the virtual Uno included).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal

__all__ = [
    "BOOT_QUIET_S",
    "BRIDGES",
    "DISCOVERY_IDS",
    "MEGA2560_USB_IDS",
    "Bridge",
    "BridgeKind",
    "boot_quiet_for_ids",
    "bridge_for_ids",
]

#: The bridge families the library tells apart (``arduinoio sim --usb-bridge`` models the
#: first three).
BridgeKind = Literal["16u2", "ftdi", "ch340", "cp210x"]


@dataclass(frozen=True, slots=True)
class Bridge:
    """One family of USB-serial bridge chips and what the library knows about it."""

    #: Short name used in logs, ``arduinoio list`` and the simulator's ``--usb-bridge``.
    kind: BridgeKind
    #: The chips, as people call them.
    name: str
    #: (vendor ID, product ID or None for the vendor's every product).
    ids: tuple[tuple[int, int | None], ...]
    #: How it passes board-to-host bytes on: what the round trip waits for.
    behaviour: str
    #: The rates it handles, in words (exact rates depend on the chip's divider).
    baud_rates: str
    #: Holds replies for a free-running tick (the 16U2): the board's low-latency mode pays.
    tick_holding: bool = False
    #: Has a host-side latency timer the library lowers to 1 ms when it opens the port.
    latency_timer: bool = False


BRIDGES: Final[tuple[Bridge, ...]] = (
    Bridge(
        kind="16u2",
        name="ATmega16U2/8U2 (arduino-usbserial: Uno, Mega 2560)",
        ids=(
            (0x2341, 0x0001),  # Uno (8U2)
            (0x2341, 0x0043),  # Uno R3 (16U2)
            (0x2341, 0x0243),  # Uno R3 (16U2, later PID)
            (0x2341, 0x0010),  # Mega 2560 (8U2)
            (0x2341, 0x0042),  # Mega 2560 R3 (16U2)
            (0x2A03, 0x0043),  # Uno R3, arduino.org IDs
            (0x2A03, 0x0042),  # Mega 2560 R3, arduino.org IDs
        ),
        behaviour="holds board-to-host bytes until its 4.096 ms Timer0 tick or until "
        "more than 96 wait (the board's low-latency mode pads replies past 96)",
        baud_rates="115200 (stock); 1,000,000 for short alternating frames; heavy two-way "
        "traffic at 250k and above has reported trouble",
        tick_holding=True,
    ),
    Bridge(
        kind="ftdi",
        name="FTDI FT232R/FT231X (and other FT-series)",
        ids=(
            (0x0403, 0x6001),  # FT232R/FT232RL/FT245R
            (0x0403, 0x6015),  # FT-X series: FT231X, FT230X
            (0x0403, None),  # the vendor's other products (FT2232, FT232H, ...)
        ),
        behaviour="holds board-to-host bytes for the driver's latency timer (16 ms on "
        "Linux by default, 1 ms minimum) or until a 62-byte packet fills",
        baud_rates="up to 3 Mbaud (3 MHz / (n + k/8)): 1 and 2 Mbaud exact",
        latency_timer=True,
    ),
    Bridge(
        kind="ch340",
        name="WCH CH340/CH341, CH9102",
        ids=(
            (0x1A86, 0x7523),  # CH340
            (0x1A86, 0x5523),  # CH341 in serial mode
            (0x1A86, 0x7522),  # CH340 (K variant)
            (0x1A86, 0x55D4),  # CH9102 (CDC ACM)
        ),
        behaviour="passes bytes on at the next USB poll (Linux's ch341 driver turns its "
        "32-byte packet buffering off); nothing to tune",
        baud_rates="50 baud to 2 Mbaud: 1 and 2 Mbaud exact (12 MHz clock)",
    ),
    Bridge(
        kind="cp210x",
        name="Silicon Labs CP210x",
        ids=(
            (0x10C4, 0xEA60),  # CP2102/CP2102N/CP2104
            (0x10C4, 0xEA70),  # CP2105
            (0x10C4, 0xEA71),  # CP2108
        ),
        behaviour="passes bytes on at the next USB poll; no latency timer to tune",
        baud_rates="CP2102: 300 baud to 1 Mbaud (older chips quantise to AN205's rate table); "
        "CP2104: up to 2 Mbaud; CP2102N: up to 3 Mbaud",
    ),
)

#: (vendor ID, product ID or None) of every USB device the manager probes: the bridges
#: above, every other Arduino device (native-USB boards) and the 16U2 in DFU mode.
DISCOVERY_IDS: Final[tuple[tuple[int, int | None], ...]] = (
    *(pair for bridge in BRIDGES for pair in bridge.ids),
    (0x2341, None),  # Arduino SA: other boards
    (0x2A03, None),  # Arduino.org
    (0x03EB, 0x2FEF),  # Atmel ATmega16U2 DFU / clones
)


def bridge_for_ids(vid: int | None, pid: int | None) -> Bridge | None:
    """The bridge a USB device with these IDs is, or None; an exact product ID wins over a
    vendor-wide entry (FTDI's 0x6001 names the FT232R, any other 0x0403 the family)."""
    if vid is None:
        return None
    wildcard: Bridge | None = None
    for bridge in BRIDGES:
        for b_vid, b_pid in bridge.ids:
            if b_vid != vid:
                continue
            if b_pid == pid:
                return bridge
            if b_pid is None and wildcard is None:
                wildcard = bridge
    return wildcard


#: Boards whose bootloader takes any byte of its boot window for a programmer's and then
#: stays in programming mode until seconds of silence: Arduino's stk500v2 on the Mega 2560
#: (its window ends 0.84 s after a reset, measured on the virtual Mega running it; the Uno's
#: optiboot instead leaves at the first byte it does not understand).  Opening the port
#: resets such a board (DTR), so the host keeps quiet this long first, in seconds.
#: The Arduino Mega 2560's USB IDs (its 8U2, then 16U2 running arduino-usbserial): the
#: board ``arduinoio flash`` picks the Mega's image and bootloader protocol for.
MEGA2560_USB_IDS: Final = ((0x2341, 0x0010), (0x2341, 0x0042))

BOOT_QUIET_S: Final[dict[tuple[int, int], float]] = {ids: 1.2 for ids in MEGA2560_USB_IDS}


def boot_quiet_for_ids(vid: int | None, pid: int | None) -> float:
    """Seconds to keep quiet after opening a board with these USB IDs (0: none)."""
    if vid is None or pid is None:
        return 0.0
    return BOOT_QUIET_S.get((vid, pid), 0.0)
