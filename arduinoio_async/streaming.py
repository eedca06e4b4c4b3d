"""The old import path of :mod:`arduinoio_async.board.streaming` (kept so that programs written
before the handles moved into ``board/`` keep working; new code imports from there)."""

from .board.streaming import *  # noqa: F403
from .board.streaming import __all__ as __all__
