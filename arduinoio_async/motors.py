"""The old import path of :mod:`arduinoio_async.board.motors` (kept so that programs written
before the handles moved into ``board/`` keep working; new code imports from there)."""

from .board.motors import *  # noqa: F403
from .board.motors import __all__ as __all__
