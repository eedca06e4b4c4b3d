"""``python -m arduinoio_async`` is the ``arduinoio`` command."""

from .cli import run

raise SystemExit(run())
