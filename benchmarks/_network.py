"""What the network benchmarks share: the served board's server process."""

from __future__ import annotations

import sys

__all__ = ["serve_command"]


def serve_command(port: str, baud: int, listen: str) -> list[str]:
    """``arduinoio serve`` for one board (no USB discovery) listening on ``listen``."""
    return [
        sys.executable,
        "-m",
        "arduinoio_async",
        "serve",
        "--no-usb",
        "--ports",
        port,
        "--baud",
        str(baud),
        "--listen",
        listen,
    ]
