"""Firmware build profiles: which optional peripheral classes each firmware image holds.

Why profiles at all: the Uno's ATmega328P has 32 KiB of flash (30 KiB once optiboot keeps
its section) and 2 KiB of RAM, of which the stack must keep at least 400 B at its deepest.
The classes this project grew (steppers, quadrature encoders, sonar, RC pulse inputs, SPI,
I2C blocks in the stream) do not all fit one Uno image under that budget, so an Uno image
is built for a job: ``standard`` (every general feature, quadrature encoders and steppers)
and ``sensing`` (the sensor board: encoders and the new sensors, without steppers).  The
core (GPIO, analog, I2C, servo, soft and duty PWM, counters, the stream, the failsafe,
transactions, CRC framing) is in every image.

This table is the single source of truth.  :mod:`.cheader` renders it into
``aio_protocol.h`` as ``AIO_WITH_<FEATURE>`` switches per ``AIO_PROFILE_<NAME>``; the
firmware's Makefile builds one image per profile; the library reads what a board holds
from the features word of its capabilities reply (never from a profile name, so a custom
build is understood as well), and uses this table only to tell a user which image has the
feature they asked for.  Pure data, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

__all__ = [
    "ALL_PROFILE",
    "DEFAULT_PROFILE",
    "OPTIONAL_FEATURES",
    "PROFILES",
    "UNO_PROFILES",
    "Profile",
    "image_stem",
    "profile",
    "profiles_with",
]

#: Feature names (members of :class:`~arduinoio_async.protocol.Feature`) an image may leave
#: out.  Names, not members, so the table can list a class before its commands land.
OPTIONAL_FEATURES: Final = ("ENCODER", "STEPPER", "SONAR", "PULSE_IN", "SPI", "I2C_STREAM")


@dataclass(frozen=True)
class Profile:
    """One firmware image's choice of optional classes."""

    #: Lower-case name: ``arduinoio flash --profile NAME``, ``VirtualUno(profile=NAME)``.
    name: str
    #: One line for the docs and the CLI's help.
    summary: str
    #: The optional features (names from OPTIONAL_FEATURES) this image holds.
    features: frozenset[str]
    #: Built and shipped for the Uno (False: a host-test or larger-board build).
    uno: bool = True

    def has(self, feature: str) -> bool:
        """Whether this image holds the optional feature named ``feature``."""
        return feature in self.features


PROFILES: Final = (
    Profile(
        "standard",
        "every general feature with quadrature encoders and steppers (the default image)",
        frozenset({"ENCODER", "STEPPER"}),
    ),
    Profile(
        "sensing",
        "the sensor board: encoders, sonar, RC pulse inputs, SPI and I2C blocks in the "
        "stream (no steppers)",
        frozenset({"ENCODER", "SONAR", "PULSE_IN", "SPI", "I2C_STREAM"}),
    ),
    Profile(
        "all",
        "every optional class (firmware host tests and fuzzing; too large for an Uno)",
        frozenset(OPTIONAL_FEATURES),
        uno=False,
    ),
)

#: The image ``arduinoio flash`` writes and a virtual Uno runs when no profile is named.
DEFAULT_PROFILE: Final = "standard"
#: The profile every optional class is compiled into (host tests, fuzzers).
ALL_PROFILE: Final = "all"
#: The profiles with an Uno image in the wheel, in the order the docs list them.
UNO_PROFILES: Final = tuple(p.name for p in PROFILES if p.uno)

_BY_NAME: Final = {p.name: p for p in PROFILES}


def profile(name: str) -> Profile:
    """The profile called ``name``; ValueError naming the choices otherwise."""
    try:
        return _BY_NAME[name]
    except KeyError:
        choices = ", ".join(UNO_PROFILES)
        raise ValueError(f"no firmware profile {name!r} (the Uno images: {choices})") from None


def profiles_with(feature: str) -> tuple[str, ...]:
    """The Uno profiles whose image holds the optional feature named ``feature``."""
    return tuple(p.name for p in PROFILES if p.uno and p.has(feature))


def image_stem(baud: int, profile_name: str = DEFAULT_PROFILE) -> str:
    """The image file's name without extension: ``arduinoio-1000000`` for the default
    profile (the name every earlier release used), ``arduinoio-sensing-1000000`` otherwise."""
    profile(profile_name)  # refuse unknown names here, with the choices
    if profile_name == DEFAULT_PROFILE:
        return f"arduinoio-{baud}"
    return f"arduinoio-{profile_name}-{baud}"
