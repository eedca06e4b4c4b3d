"""Seed inputs for the firmware's fuzz targets, from the protocol vectors (tests/vectors).

    python firmware/tests/fuzz_seeds.py     # writes firmware/tests/corpus/<target>/seed-*

Each vector file becomes one input per target, in that target's input format (see
fuzz_parser.c, fuzz_frames.c, fuzz_dispatch.c): every request the vectors know, in an
order that configures pins before using them, so mutations start from frames the board
accepts.  `make -C firmware fuzz-merge` adds what fuzzing finds beyond them.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from arduinoio_async import protocol as p  # noqa: E402
from tests.vectors.vectors import Drive, load_all  # noqa: E402

CORPUS = Path(__file__).resolve().parent / "corpus"
#: The order of AIO_REQUEST_TABLE (the generated header lists requests by CT, then DT).
TABLE = sorted(p.REQUEST_TYPES)


def main() -> None:
    for target in ("parser", "frames", "dispatch"):
        (CORPUS / target).mkdir(parents=True, exist_ok=True)
    for vectors in load_all():
        parser, frames, dispatch = bytearray(), bytearray(), bytearray()
        for step in vectors.steps:
            if isinstance(step, Drive):
                frames += bytes((0xFE, step.pin))
                dispatch += bytes((0xF1, step.pin))
                continue
            request = step.request
            parser += request
            body = request[:-1]
            frames += bytes((len(body),)) + body
            if (body[0], body[1]) in TABLE:
                dispatch += bytes((TABLE.index((body[0], body[1])),)) + body[2:]
        for target, data in (("parser", parser), ("frames", frames), ("dispatch", dispatch)):
            (CORPUS / target / f"seed-{vectors.name}").write_bytes(bytes(data))


if __name__ == "__main__":
    main()
