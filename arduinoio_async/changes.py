"""The old import path of :mod:`arduinoio_async.board.changes` (kept so that programs written
before the handles moved into ``board/`` keep working; new code imports from there)."""

from .board.changes import *  # noqa: F403
from .board.changes import __all__ as __all__
