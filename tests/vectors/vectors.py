"""Reader of the ``*.vec`` files, and the C array the firmware's host tests include.

Format, one step a line (``#`` starts a comment):

* ``id 0x0102`` -- the board ID in EEPROM when the file starts (each file runs on a
  fresh board);
* ``> 02 01 0D 03 : 02 01 0D 03`` -- send the request, expect exactly that reply; both
  without their checksum, which the runners add; ``??`` matches any byte (a value that
  depends on the circuit, such as a temperature); ``error CODE`` stands for the error
  reply ``CT|0x80 DT code`` to the request's tags;
* ``drive 7 1`` -- the circuit drives pin D7 high (or ``0`` low) from outside;
* ``profile sensing`` -- the firmware image the virtual Uno runs the file on (a class
  only some images hold; the host tests build every class, the FakeBoard models them all).

Framing: a file starts in the paper's XOR framing; a SET_FRAMING step (``> 01 0B 01``)
that succeeds switches it: its reply and every later frame, both ways, carry the
framing's check bytes (two CRC-16 bytes for mode 1).  ``Exchange.crc`` says which
framing a step's reply is in (the runners decode it so).

``python -m tests.vectors.vectors`` writes ``firmware/tests/vectors.h``; a test fails when
it differs from what this module would write.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path

from arduinoio_async.protocol import ERROR_FLAG, ErrorCode, checksum, crc16

__all__ = ["Drive", "Exchange", "VectorFile", "load_all", "render_c_header"]

HERE = Path(__file__).resolve().parent
C_HEADER = HERE.parents[1] / "firmware" / "tests" / "vectors.h"
ANY = -1


@dataclass(frozen=True, slots=True)
class Exchange:
    line: int
    request: bytes  # with checksum
    reply: tuple[int, ...]  # with checksum; ANY where any byte will do
    crc: bool = False  # the reply is in CRC-16 framing

    def matches(self, got: bytes) -> bool:
        return len(got) == len(self.reply) and all(
            want in (ANY, byte) for want, byte in zip(self.reply, got, strict=True)
        )

    def describe(self) -> str:
        want = " ".join("??" if b == ANY else f"{b:02X}" for b in self.reply)
        return f"line {self.line}: {self.request.hex(' ').upper()} -> {want}"


@dataclass(frozen=True, slots=True)
class Drive:
    line: int
    pin: int
    level: bool


Step = Exchange | Drive


@dataclass(frozen=True, slots=True)
class VectorFile:
    name: str
    board_id: int
    steps: tuple[Step, ...]
    profile: str = "standard"


def _hex_bytes(text: str, line: int) -> list[int]:
    out = []
    for token in text.split():
        if token == "??":
            out.append(ANY)
        elif re.fullmatch(r"[0-9A-Fa-f]{2}", token):
            out.append(int(token, 16))
        else:
            raise ValueError(f"line {line}: {token!r} is not a hex byte")
    return out


def _with_checksum(body: list[int], crc: bool = False) -> tuple[int, ...]:
    if crc:
        if ANY in body:
            return (*body, ANY, ANY)
        value = crc16(bytes(body))
        return (*body, value >> 8, value & 0xFF)
    if ANY in body:
        return (*body, ANY)
    return (*body, checksum(bytes(body)))


SET_FRAMING = (0x01, 0x0B)


def parse(name: str, text: str) -> VectorFile:
    board_id = 0xFFFF
    profile = "standard"
    steps: list[Step] = []
    crc = False
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith("id "):
            board_id = int(line[3:], 0)
        elif line.startswith("profile "):
            profile = line.split()[1]
        elif line.startswith("drive "):
            _, pin, level = line.split()
            steps.append(Drive(number, int(pin), level == "1"))
        elif line.startswith(">"):
            request_text, reply_text = line[1:].split(":")
            request = _hex_bytes(request_text, number)
            if ANY in request:
                raise ValueError(f"line {number}: a request cannot contain ??")
            reply_text = reply_text.strip()
            framed_request = bytes(_with_checksum(request, crc))
            if reply_text.startswith("error "):
                code = ErrorCode[reply_text.split()[1]]
                reply = [request[0] | ERROR_FLAG, request[1], int(code)]
            else:
                reply = _hex_bytes(reply_text, number)
                if tuple(request[:2]) == SET_FRAMING:
                    crc = request[2] == 1  # the reply is in the new framing already
            steps.append(Exchange(number, framed_request, _with_checksum(reply, crc), crc))
        else:
            raise ValueError(f"{name} line {number}: cannot read {raw!r}")
    return VectorFile(name, board_id, tuple(steps), profile)


def load_all() -> list[VectorFile]:
    return [parse(path.stem, path.read_text()) for path in sorted(HERE.glob("*.vec"))]


def render_c_header(files: list[VectorFile]) -> str:
    """The vectors as C data for ``firmware/tests/test_vectors.c`` (replies: -1 = any byte)."""
    out = [
        "/* Generated from tests/vectors (python -m tests.vectors.vectors): do not edit. */",
        "#ifndef AIO_TEST_VECTORS_H",
        "#define AIO_TEST_VECTORS_H",
        "#include <stdint.h>",
        "",
        "typedef struct {",
        "    uint16_t line;",
        "    int8_t drive_pin; /* >= 0: a drive step (drive_level), else an exchange */",
        "    uint8_t drive_level;",
        "    uint8_t request_len;",
        "    uint8_t request[40];",
        "    uint8_t reply_len;",
        "    int16_t reply[40];",
        "} aio_vector_step_t;",
        "",
        "typedef struct {",
        "    const char *name;",
        "    uint16_t board_id;",
        "    uint16_t count;",
        "    const aio_vector_step_t *steps;",
        "} aio_vector_file_t;",
        "",
    ]
    for vf in files:
        out.append(f"static const aio_vector_step_t aio_vectors_{vf.name}[] = {{")
        for step in vf.steps:
            if isinstance(step, Drive):
                out.append(
                    f"    {{{step.line}, {step.pin}, {int(step.level)}, 0, {{0}}, 0, {{0}}}},"
                )
            else:
                request = ", ".join(str(b) for b in step.request)
                reply = ", ".join(str(b) for b in step.reply)
                out.append(
                    f"    {{{step.line}, -1, 0, {len(step.request)}, {{{request}}}, "
                    f"{len(step.reply)}, {{{reply}}}}},"
                )
        out.append("};")
        out.append("")
    out.append("static const aio_vector_file_t aio_vector_files[] = {")
    for vf in files:
        out.append(
            f'    {{"{vf.name}", 0x{vf.board_id:04X}, {len(vf.steps)}, aio_vectors_{vf.name}}},'
        )
    out.append("};")
    out.append("")
    out.append("#endif")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    C_HEADER.write_text(render_c_header(load_all()))
    sys.stdout.write(f"wrote {C_HEADER}\n")
