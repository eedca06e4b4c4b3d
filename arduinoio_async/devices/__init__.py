"""Device drivers on the board's bridges: typed helpers for common parts.

Each driver is plain code over a bus handle (an :class:`~arduinoio_async.board.spi.SpiBus`,
the I2C bus), an example of how a device's datasheet becomes a few lines on the bridge.
"""

from __future__ import annotations

from .mcp3008 import MCP3008

__all__ = ["MCP3008"]
