"""Hypothesis strategies that build any message of the command table from its layout."""

from __future__ import annotations

from enum import IntEnum, IntFlag
from typing import Any

from hypothesis import strategies as st

from arduinoio_async import protocol as p
from arduinoio_async.protocol._layout import Array, Blob, FieldSpec, Frame, Scalar


def _field(spec: FieldSpec) -> st.SearchStrategy[Any]:
    wire = spec.wire
    if isinstance(wire, Blob):
        return st.binary(max_size=wire.max_length)
    if isinstance(wire, Array):
        item = st.integers(0, (1 << (8 * wire.item.size)) - 1)
        return st.tuples(*[item] * wire.count)
    assert isinstance(wire, Scalar)
    if spec.pytype is bool:
        return st.booleans()
    if issubclass(spec.pytype, IntFlag):
        flag_bits = 0
        for member in spec.pytype:
            flag_bits |= int(member)
        return st.integers(0, flag_bits).map(spec.pytype)
    if issubclass(spec.pytype, IntEnum):
        return st.sampled_from(list(spec.pytype))
    if wire.code.islower():  # signed (stepper positions and speeds, an encoder's count)
        half = 1 << (8 * wire.size - 1)
        return st.integers(-half, half - 1)
    return st.integers(0, (1 << (8 * wire.size)) - 1)


_ADC = st.integers(0, 1023)
#: Fields whose replies validate a narrower range than their wire type.
_OVERRIDES: dict[tuple[type[Frame], str], st.SearchStrategy[Any]] = {
    (p.ReadTemperatureReply, "raw"): _ADC,
    (p.AnalogReadReply, "value"): _ADC,
    (p.AnalogReadAllReply, "values"): st.tuples(*[_ADC] * 6),
    (p.AnalogWatchReply, "value"): _ADC,
    (p.AnalogChange, "value"): _ADC,
    (p.GpioChange, "state"): st.sampled_from(
        [p.GpioState.HIGH | p.GpioState.ROSE, p.GpioState.FELL]
    ),
}


def message(cls: type[Frame]) -> st.SearchStrategy[Frame]:
    """Any valid instance of ``cls``."""
    if cls is p.StreamSample:
        return _stream_sample()
    fields = {
        spec.name: _OVERRIDES[(cls, spec.name)] if (cls, spec.name) in _OVERRIDES else _field(spec)
        for spec in cls.LAYOUT.fields
    }
    return st.builds(cls, **fields)


def _stream_sample() -> st.SearchStrategy[Frame]:
    @st.composite
    def build(draw: st.DrawFn) -> Frame:
        mask = draw(st.integers(0, 0x3F))
        flags = p.StreamFlags(draw(st.integers(0, 15)))
        size = p.sample_payload_size(mask, flags)
        if size > p.MAX_BLOB:  # the board refuses such a stream (STEPPERS with much else)
            flags &= ~p.StreamFlags.STEPPERS
            size = p.sample_payload_size(mask, flags)
        return p.StreamSample(
            analog_mask=mask,
            flags=flags,
            sequence=draw(st.integers(0, 0xFFFF)),
            timestamp_us=draw(st.integers(0, 0xFFFFFFFF)),
            payload=draw(st.binary(min_size=size, max_size=size)),
        )

    return build()


error_replies = st.builds(
    p.ErrorReply,
    class_tag=st.integers(0, 0x7F),
    descriptor=st.integers(0, 0xFF),
    code=st.sampled_from(list(p.ErrorCode)),
)

requests = st.one_of(*[message(cls) for cls in p.REQUEST_TYPES.values()])
board_frames = st.one_of(
    *[message(cls) for cls in p.REPLY_TYPES.values()],
    *[message(cls) for cls in p.EVENT_TYPES.values()],
    error_replies,
)
