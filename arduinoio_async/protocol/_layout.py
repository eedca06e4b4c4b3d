"""Wire layouts compiled from annotated dataclasses.

Theory of operation: a message is a frozen dataclass whose fields carry their wire type in
``Annotated[...]`` metadata (``U8``, ``U16``, ``U32``, ``Array``, ``Blob``).  The ``frame``
decorator compiles that into a :class:`Layout` once, at import: one ``struct.Struct`` for
the fixed part and, for the one variable field a frame may have, a length byte followed by
the bytes.  Encoding and decoding are then a single ``pack``/``unpack_from`` each, which
keeps the host's cost per command in the low microseconds.

Every frame is ``CT DT D0..Dn CS`` with ``CS`` the XOR of all bytes before it, so the XOR
of a whole valid frame is zero.  A frame's length follows from ``(CT, DT)``, plus the value
of its length byte where it has a ``Blob``.  Layouts encode this, the paper's framing; a
link that negotiated CRC-16 framing (``SetFraming``) replaces the XOR byte by two CRC
bytes with :func:`crc_framed`, and its decoder checks them (one byte longer, same fields).
"""

from __future__ import annotations

import binascii
import dataclasses
import operator
import struct
import typing
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum, IntFlag
from typing import Any, ClassVar, TypeVar

from ..errors import FieldRangeError

__all__ = [
    "I16",
    "I32",
    "U8",
    "U16",
    "U32",
    "Array",
    "Blob",
    "Frame",
    "Layout",
    "checksum",
    "crc16",
    "crc_framed",
]


@dataclass(frozen=True, slots=True)
class Scalar:
    """A big-endian integer of ``size`` bytes (unsigned unless its struct code is lower case)."""

    code: str
    size: int
    name: str


U8 = Scalar("B", 1, "u8")
U16 = Scalar("H", 2, "u16 (big-endian)")
U32 = Scalar("I", 4, "u32 (big-endian)")
#: Signed (two's complement): stepper positions and speeds.
I16 = Scalar("h", 2, "i16 (big-endian)")
#: Signed (two's complement): an encoder's count goes both ways.
I32 = Scalar("i", 4, "i32 (big-endian)")


@dataclass(frozen=True, slots=True)
class Array:
    """A fixed number of scalars, decoded to a tuple."""

    item: Scalar
    count: int


@dataclass(frozen=True, slots=True)
class Blob:
    """A length byte followed by that many bytes; at most one per frame, always last."""

    max_length: int


WireType = Scalar | Array | Blob


def checksum(data: bytes | bytearray | memoryview) -> int:
    """XOR of all bytes (the paper's Eq. 1)."""
    value = 0
    for byte in data:
        value ^= byte
    return value


#: CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection, no final
#: XOR (``binascii.crc_hqx`` computes this polynomial unreflected, in C).
CRC16_INIT = 0xFFFF


def crc16(data: bytes | bytearray | memoryview) -> int:
    """CRC-16/CCITT-FALSE of ``data``; 0 over a whole CRC-framed frame (CRC big-endian)."""
    return binascii.crc_hqx(data, CRC16_INIT)


def crc_framed(frame: bytes) -> bytes:
    """An XOR-framed frame (its last byte the XOR) as a CRC-16 frame: the same bytes
    without the XOR byte, then their CRC-16, high byte first."""
    body = frame[:-1]
    return body + binascii.crc_hqx(body, CRC16_INIT).to_bytes(2, "big")


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """One compiled field: its name, wire type and the Python type it decodes to."""

    name: str
    wire: WireType
    pytype: type[Any]

    @property
    def size(self) -> int:
        """Bytes on the wire; a Blob counts only its length byte."""
        if isinstance(self.wire, Scalar):
            return self.wire.size
        if isinstance(self.wire, Array):
            return self.wire.item.size * self.wire.count
        return 1


def _converter(pytype: type[Any]) -> Callable[[int], Any] | None:
    if pytype is bool:

        def to_bool(value: int) -> bool:
            if value > 1:
                raise ValueError(f"boolean byte {value}")
            return value == 1

        return to_bool
    if isinstance(pytype, type) and issubclass(pytype, IntFlag):
        return pytype
    if isinstance(pytype, type) and issubclass(pytype, IntEnum):
        return pytype
    return None


class Layout:
    """How one message class sits on the wire."""

    def __init__(self, cls: type[Frame], class_tag: int, descriptor: int) -> None:
        self.cls = cls
        self.class_tag = class_tag
        self.descriptor = descriptor
        self.fields = _field_specs(cls)
        blobs = [f for f in self.fields if isinstance(f.wire, Blob)]
        if blobs and blobs[0] is not self.fields[-1]:
            raise TypeError(f"{cls.__name__}: a Blob must be the last field")
        self.blob: FieldSpec | None = blobs[0] if blobs else None
        fixed = self.fields[:-1] if self.blob else self.fields
        self.fixed_fields = fixed
        codes = "".join(
            f.wire.code if isinstance(f.wire, Scalar) else f"{f.wire.count}{f.wire.item.code}"
            for f in fixed
            if not isinstance(f.wire, Blob)
        )
        self.prefix = struct.Struct(">BB" + codes + ("B" if self.blob else ""))
        #: Frame length without blob bytes: CT, DT, fixed fields, length byte, CS.
        self.base_size = self.prefix.size + 1
        #: Offset of the length byte from the frame start, or -1 without a Blob.
        self.length_offset = self.prefix.size - 1 if self.blob else -1
        self.max_size = self.base_size + (
            self.blob.wire.max_length if self.blob and isinstance(self.blob.wire, Blob) else 0
        )
        self._converters = [_converter(f.pytype) for f in fixed]
        self._array_counts = [f.wire.count if isinstance(f.wire, Array) else 0 for f in fixed]
        self._simple = all(c is None for c in self._converters) and not any(self._array_counts)
        # Encoding is on every request's path: a frame without fields is a constant, and
        # one of scalar fields only packs the fields fetched by one ``attrgetter`` call.
        self.constant: bytes | None = None
        #: The same frame with a CRC-16 (negotiated framing, ``SetFraming``).
        self.crc_constant: bytes | None = None
        self._getter: Callable[[Any], Any] | None = None
        if not self.fields:
            head = self.prefix.pack(class_tag, descriptor)
            self.constant = head + bytes((checksum(head),))
            self.crc_constant = crc_framed(self.constant)
        elif self.blob is None and not any(self._array_counts):
            names = [f.name for f in fixed]
            getter = operator.attrgetter(*names)
            self._getter = getter if len(names) > 1 else lambda message: (getter(message),)

    @property
    def data_size(self) -> int:
        """Data bytes between DT and CS, without blob bytes (with the length byte)."""
        return self.base_size - 3

    def encode(self, message: Frame) -> bytes:
        """The frame's bytes, checksum included."""
        if self.constant is not None:
            return self.constant
        if self._getter is not None:
            try:
                body = self.prefix.pack(self.class_tag, self.descriptor, *self._getter(message))
            except struct.error as exc:
                raise FieldRangeError(f"{message!r} does not fit its wire layout: {exc}") from exc
            check = 0
            for byte in body:
                check ^= byte
            return body + bytes((check,))
        values: list[Any] = [self.class_tag, self.descriptor]
        for spec in self.fixed_fields:
            value = getattr(message, spec.name)
            if isinstance(spec.wire, Array):
                values.extend(value)
            else:
                values.append(value)
        blob = b""
        if self.blob is not None:
            blob = bytes(getattr(message, self.blob.name))
            assert isinstance(self.blob.wire, Blob)
            if len(blob) > self.blob.wire.max_length:
                raise FieldRangeError(
                    f"{type(message).__name__}.{self.blob.name}: {len(blob)} bytes, "
                    f"at most {self.blob.wire.max_length}"
                )
            values.append(len(blob))
        try:
            head = self.prefix.pack(*values)
        except struct.error as exc:
            raise FieldRangeError(f"{message!r} does not fit its wire layout: {exc}") from exc
        body = head + blob
        return body + bytes((checksum(body),))

    def decode(self, frame: bytes | bytearray | memoryview) -> Frame:
        """Build the message from one whole, checksum-verified frame.

        Raises ``ValueError`` when a field holds a value its type does not allow; the
        decoder turns that into garbage rather than a frame.
        """
        raw = self.prefix.unpack_from(frame)
        if self._simple and self.blob is None:
            return self.cls(*raw[2:])
        values: list[Any] = []
        index = 2
        for convert, count in zip(self._converters, self._array_counts, strict=True):
            if count:
                values.append(tuple(raw[index : index + count]))
                index += count
                continue
            value = raw[index]
            values.append(convert(value) if convert is not None else value)
            index += 1
        if self.blob is not None:
            length = raw[index]
            start = self.prefix.size
            values.append(bytes(frame[start : start + length]))
        return self.cls(*values)

    def describe(self) -> list[tuple[str, str]]:
        """(field name, wire description) pairs, for the generated docs."""
        rows: list[tuple[str, str]] = []
        for spec in self.fields:
            wire = spec.wire
            if isinstance(wire, Scalar):
                rows.append((spec.name, wire.name))
            elif isinstance(wire, Array):
                rows.append((spec.name, f"{wire.count} x {wire.item.name}"))
            else:
                rows.append((f"{spec.name}_length", "u8"))
                rows.append((spec.name, f"u8[{spec.name}_length], at most {wire.max_length}"))
        return rows


def _field_specs(cls: type[Any]) -> tuple[FieldSpec, ...]:
    hints = typing.get_type_hints(cls, include_extras=True)
    specs: list[FieldSpec] = []
    for field in dataclasses.fields(cls):
        hint = hints[field.name]
        if typing.get_origin(hint) is not typing.Annotated:
            raise TypeError(f"{cls.__name__}.{field.name} has no wire type")
        pytype, *meta = typing.get_args(hint)
        wires = [m for m in meta if isinstance(m, Scalar | Array | Blob)]
        if len(wires) != 1:
            raise TypeError(f"{cls.__name__}.{field.name} needs exactly one wire type")
        origin = typing.get_origin(pytype) or pytype
        specs.append(FieldSpec(field.name, wires[0], origin))
    return tuple(specs)


class Frame:
    """Base of every message; ``LAYOUT`` is set by the ``frame`` decorator."""

    __slots__ = ()
    LAYOUT: ClassVar[Layout]

    def encode(self) -> bytes:
        """This message as frame bytes."""
        return self.LAYOUT.encode(self)


F = TypeVar("F", bound=type[Frame])


def frame(class_tag: int, descriptor: int) -> Callable[[F], F]:
    """Attach a compiled layout to a frozen dataclass message."""

    def attach(cls: F) -> F:
        cls.LAYOUT = Layout(cls, class_tag, descriptor)
        return cls

    return attach
