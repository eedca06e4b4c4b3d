"""Where a command's time goes: wire + firmware + USB bridge + host.

All constants come from the hardware, not from fitting the paper:

* wire: 10 bit times per byte at the link's rate, each direction (simavr's UART model
  counts 11 bit times for bytes the AVR sends, so the virtual Uno's board-to-host wire
  time is 10 % longer than a real one; the model follows whichever link it predicts);
* firmware: measured in simulated cycles by the harness, at 16 MHz;
* the ATmega16U2 bridge (``arduino-usbserial``): bytes from the AVR wait for its
  free-running 4.096 ms timer tick (uniform phase: 2.048 ms on average), then for the next
  1 ms USB full-speed frame (0.5 ms on average); bytes from the host wait for the next USB
  frame too (0.5 ms on average);
* host: the library's own time per command, measured by the host-overhead scenario.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["PAPER_LINK", "LinkModel", "predict_ms"]

F_CPU = 16_000_000


@dataclass(frozen=True)
class LinkModel:
    """A link: rates in baud, bit times per byte each way, bridge on or off."""

    baud_to_board: float = 115_200
    baud_to_host: float = 115_200
    bits_to_board: float = 10
    bits_to_host: float = 10
    bridge_16u2: bool = True
    #: The 16U2 firmware's flush tick and the USB full-speed frame.
    tick_ms: float = 4.096
    usb_frame_ms: float = 1.0

    def wire_ms(self, request_bytes: int, reply_bytes: int) -> float:
        to_board = request_bytes * self.bits_to_board / self.baud_to_board
        to_host = reply_bytes * self.bits_to_host / self.baud_to_host
        return (to_board + to_host) * 1e3

    def bridge_ms(self) -> float:
        """Mean wait added by the bridge: tick phase plus a USB frame each way."""
        if not self.bridge_16u2:
            return 0.0
        return self.tick_ms / 2 + self.usb_frame_ms / 2 + self.usb_frame_ms / 2


#: The real Uno of the paper: 115200 baud is UBRR 16 with U2X, 117,647 baud (+2.1 %).
PAPER_LINK = LinkModel(baud_to_board=117_647, baud_to_host=117_647)


def predict_ms(
    link: LinkModel,
    request_bytes: int,
    reply_bytes: int,
    firmware_cycles: float,
    host_ms: float,
) -> float:
    """Mean latency of one request/response under ``link``."""
    return (
        link.wire_ms(request_bytes, reply_bytes)
        + firmware_cycles / F_CPU * 1e3
        + link.bridge_ms()
        + host_ms
    )
