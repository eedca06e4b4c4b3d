"""What a board can send, beyond what a reply's wire type allows.

An 8-bit XOR lets some damaged replies through (see :mod:`.session`, "Checksum blind
spots").  A message class refuses values its type forbids (a 10-bit ADC value above 1023);
here are the bounds that depend on the board and the link rather than on the format: the
board's own ID, and the readings the chip's temperature sensor can physically give.  The
session treats a reply outside them as line noise, so an idempotent read is asked again
instead of answering with a wrong value.
"""

from __future__ import annotations

from collections.abc import Set

from ._constants import TEMP_MV_AT_25C, TEMP_MV_PER_C
from ._messages import Reply
from .commands.misc import ReadIdReply, ReadTemperatureReply
from .commands.transaction import TransactionReply, split_results

__all__ = ["BOUNDED", "TEMPERATURE_RAW_RANGE", "possible"]

#: Raw readings the chip's temperature sensor can give (ATmega328P datasheet, "Temperature
#: Measurement": about 1 mV per degree, 314 mV at 25 C, +/-10 mV before calibration),
#: for a die between -60 C and +150 C (beyond its absolute maximum ratings) and an internal
#: reference between 1.0 V and 1.2 V (its specified spread around 1.1 V): 186-459.
TEMPERATURE_RAW_RANGE = range(
    int((TEMP_MV_AT_25C + (-60 - 25) * TEMP_MV_PER_C - 10) * 1024 / 1200),
    int((TEMP_MV_AT_25C + (150 - 25) * TEMP_MV_PER_C + 10) * 1024 / 1000) + 1,
)

#: Reply types :func:`possible` bounds (a set lookup keeps the others' path cheap).
BOUNDED = frozenset((ReadIdReply, ReadTemperatureReply, TransactionReply))


def possible(reply: Reply, expected_id: int | None, candidate_ids: Set[int]) -> bool:
    """Could the board have sent ``reply``?  An ID reply must name the board's ID
    (``expected_id``; None: any) or one a ``WriteId`` in doubt may have set
    (``candidate_ids``); a temperature must lie in :data:`TEMPERATURE_RAW_RANGE`; a
    transaction's results must be whole replies, each of them possible."""
    if isinstance(reply, ReadIdReply):
        return (
            expected_id is None or reply.board_id == expected_id or reply.board_id in candidate_ids
        )
    if isinstance(reply, ReadTemperatureReply):
        return reply.raw in TEMPERATURE_RAW_RANGE
    if isinstance(reply, TransactionReply):
        results = split_results(reply.results)
        return results is not None and all(
            possible(item, expected_id, candidate_ids)
            for item in results
            if isinstance(item, Reply)
        )
    return True
