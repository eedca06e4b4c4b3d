"""The old import path of :mod:`arduinoio_async.board.transactions` (kept so that programs written
before the handles moved into ``board/`` keep working; new code imports from there)."""

from .board.transactions import *  # noqa: F403
from .board.transactions import __all__ as __all__
