"""The options every ``arduinoio`` command that looks for boards shares.

``--ports`` (more places to probe), ``--baud`` and ``--probe-timeout``, and the argument
types that turn a board ID, a baud rate or a number of seconds into a one-line error
instead of a traceback (``--ports`` itself is the manager's, whose ``patterns`` it fills).
A public module of its own, below the command line and the monitor, so each of them
builds the same options without importing another's private module.
"""

from __future__ import annotations

import argparse
import math

from .manager import add_ports_option
from .protocol import DEFAULT_BAUD

__all__ = ["add_scan_options", "baud_rate", "board_id", "probe_seconds"]


def board_id(text: str) -> int:
    """A board ID, 0x0000-0xFFFF (decimal or ``0x`` hex)."""
    value = int(text, 0)
    if not 0 <= value <= 0xFFFF:
        raise argparse.ArgumentTypeError(f"board ID must be 0x0000-0xFFFF, got {text}")
    return value


def baud_rate(text: str) -> int:
    """A positive whole number of bits per second."""
    try:
        value = int(text, 10)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError(f"baud rate must be a positive whole number, got {text}")
    return value


def probe_seconds(text: str) -> float:
    """A finite, positive number of seconds (NaN or a negative deadline never ends well)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(
            f"probe timeout must be a positive number of seconds, got {text}"
        )
    return value


def add_scan_options(parser: argparse.ArgumentParser) -> None:
    """``--ports``, ``--baud`` and ``--probe-timeout`` (the ports a scan probes, and how)."""
    add_ports_option(parser)
    parser.add_argument("--baud", type=baud_rate, default=DEFAULT_BAUD)
    parser.add_argument(
        "--probe-timeout", type=probe_seconds, default=5.0, help="seconds per port (auto-reset)"
    )
