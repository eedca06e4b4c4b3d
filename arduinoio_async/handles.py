"""The old import path of :mod:`arduinoio_async.board.handles` (kept so that programs written
before the handles moved into ``board/`` keep working; new code imports from there)."""

from .board.handles import *  # noqa: F403
from .board.handles import __all__ as __all__
