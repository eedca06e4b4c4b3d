"""What a fake board does wrong: a seeded, replayable model of a bad line and a slow board."""

from __future__ import annotations

import random
from dataclasses import dataclass

__all__ = ["Faults", "corrupt"]


@dataclass
class Faults:
    """What the fake board does wrong; probabilities are per reply or per byte."""

    seed: int = 0
    #: Send each reply in random pieces (down to single bytes).
    split: bool = False
    #: Probability that random garbage bytes precede a reply.
    garbage: float = 0.0
    #: Per-byte probabilities on the board-to-host direction.
    drop_byte: float = 0.0
    insert_byte: float = 0.0
    flip_byte: float = 0.0
    #: Probability that a request gets no reply at all.
    lose_reply: float = 0.0
    #: Each reply waits a random time in this range (seconds) before it is sent.
    delay: tuple[float, float] = (0.0, 0.0)


def corrupt(frame: bytes, faults: Faults, rnd: random.Random) -> bytes:
    """``frame`` as the line delivers it: with garbage before it, bytes dropped, flipped or
    inserted, each drawn from ``rnd`` so that a failing case can be replayed by its seed."""
    out = bytearray()
    if faults.garbage and rnd.random() < faults.garbage:
        out += bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 6)))
    for byte in frame:
        if faults.drop_byte and rnd.random() < faults.drop_byte:
            continue
        if faults.flip_byte and rnd.random() < faults.flip_byte:
            byte ^= 1 << rnd.randrange(8)
        out.append(byte)
        if faults.insert_byte and rnd.random() < faults.insert_byte:
            out.append(rnd.randrange(256))
    return bytes(out)
