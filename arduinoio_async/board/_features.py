"""What a board's firmware image holds: the check every optional class makes first.

An Uno image is built for a job (:mod:`arduinoio_async.protocol.profiles`), so a handle of
an optional class (encoders, steppers, sonar, RC pulse inputs, SPI, I2C stream blocks)
asks here before it sends its set-up: the answer comes from the features word the board
announced in its capabilities reply, never from a profile name, so a custom build is
judged by what it says it holds.  The error names the shipped images that have the
feature, which is the one thing a user cannot guess.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from .. import protocol as p
from ..errors import FirmwareFeatureError
from ..protocol.profiles import profiles_with

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = [
    "STREAM_FLAG_FEATURES",
    "FeatureMethods",
    "has_feature",
    "require_feature",
    "require_stream_features",
]

#: The stream flags an optional class adds: the feature that carries each, in words.
STREAM_FLAG_FEATURES: dict[p.StreamFlags, tuple[p.Feature, str]] = {
    p.StreamFlags.ENCODERS: (p.Feature.ENCODER, "quadrature encoders"),
    p.StreamFlags.STEPPERS: (p.Feature.STEPPER, "steppers"),
    p.StreamFlags.SONAR: (p.Feature.SONAR, "sonars"),
    p.StreamFlags.PULSE_IN: (p.Feature.PULSE_IN, "pulse-width inputs"),
    p.StreamFlags.I2C: (p.Feature.I2C_STREAM, "I2C blocks"),
}


def has_feature(board: BoardCore, feature: p.Feature) -> bool:
    """Whether ``board``'s firmware announced ``feature``."""
    return bool(board.capabilities.features & feature)


def require_feature(board: BoardCore, feature: p.Feature, what: str) -> None:
    """Raise FirmwareFeatureError (before anything is sent) unless ``board`` has ``feature``.

    ``what`` names the feature in words (``"quadrature encoders"``).
    """
    if not has_feature(board, feature):
        name = feature.name or f"0x{int(feature):X}"
        raise FirmwareFeatureError(f"board 0x{board.board_id:04X}", what, name, profiles_with(name))


def require_stream_features(board: BoardCore, flags: p.StreamFlags) -> None:
    """Raise FirmwareFeatureError unless ``board`` holds the class of every flag set."""
    for flag, (feature, what) in STREAM_FLAG_FEATURES.items():
        if flags & flag:
            require_feature(board, feature, f"{what} in the stream")


class FeatureMethods:
    """``board.require_feature()``, mixed into :class:`~arduinoio_async.board.Board`."""

    def require_feature(self, feature: p.Feature, what: str) -> None:
        """Raise :class:`~arduinoio_async.errors.FirmwareFeatureError`, before anything is
        sent, unless this board's firmware announced ``feature`` (``what`` names it in
        words); the message names the firmware images that have it."""
        require_feature(cast("BoardCore", self), feature, what)
