"""The build-profile table: names, file names and the header switches it renders."""

from __future__ import annotations

import pytest

from arduinoio_async.errors import FirmwareFeatureError, UsageError
from arduinoio_async.protocol import cheader
from arduinoio_async.protocol.profiles import (
    ALL_PROFILE,
    DEFAULT_PROFILE,
    OPTIONAL_FEATURES,
    PROFILES,
    UNO_PROFILES,
    image_stem,
    profile,
    profiles_with,
)


def test_names_are_unique_and_the_default_is_an_uno_image() -> None:
    names = [p.name for p in PROFILES]
    assert len(names) == len(set(names))
    assert DEFAULT_PROFILE in UNO_PROFILES
    assert ALL_PROFILE not in UNO_PROFILES
    assert profile(ALL_PROFILE).features == frozenset(OPTIONAL_FEATURES)
    for prof in PROFILES:
        assert prof.features <= frozenset(OPTIONAL_FEATURES), prof.name


def test_every_optional_class_is_in_some_uno_image() -> None:
    for feature in OPTIONAL_FEATURES:
        assert profiles_with(feature), f"no Uno image holds {feature}"


def test_the_default_image_keeps_the_old_file_names() -> None:
    assert image_stem(1_000_000) == "arduinoio-1000000"
    assert image_stem(115_200, "sensing") == "arduinoio-sensing-115200"
    with pytest.raises(ValueError, match="standard, sensing"):
        image_stem(115_200, "everything")


def test_the_header_switches_follow_the_table() -> None:
    text = cheader.render()
    for prof in PROFILES:
        if prof.name == DEFAULT_PROFILE:
            continue
        block = text.split(f"defined(AIO_PROFILE_{prof.name.upper()})\n", 1)[1].split("#e", 1)[0]
        for feature in OPTIONAL_FEATURES:
            assert f"#define AIO_WITH_{feature} {int(prof.has(feature))}\n" in block


def test_the_error_names_the_images_and_the_command() -> None:
    error = FirmwareFeatureError("board 0x0001", "steppers", "STEPPER", ("standard",))
    assert isinstance(error, UsageError)
    assert str(error) == (
        "board 0x0001's firmware has no steppers (its capabilities lack the STEPPER "
        "feature); the 'standard' image has it: arduinoio flash --profile standard"
    )
