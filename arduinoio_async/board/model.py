"""The model of the board a :class:`~arduinoio_async.board.Board` talks to (issue 29).

A board whose firmware has Feature.BOARD_DESCRIPTION says which board it is and which of
its pins can do what (READ_BOARD_DESCRIPTION, docs/protocol.md 7.9); the handle factories
check every pin against that before anything is sent.  An older image cannot say: it is
an Uno (every image before the description was built for the Uno), so its model is
:data:`~arduinoio_async.protocol.boards.UNO_R3`, the paper's Table III.
"""

from __future__ import annotations

import logging

from .. import protocol as p
from ..errors import ProtocolError
from ..protocol.boards import UNO_R3, BoardModel, model_from_pages
from ..transport import Transport

__all__ = ["BoardModel", "read_board_model"]

logger = logging.getLogger(__name__)


async def read_board_model(link: Transport, capabilities: p.ReadCapabilitiesReply) -> BoardModel:
    """The board's model: page 0 of its description, then the other pages pipelined."""
    if not capabilities.features & p.Feature.BOARD_DESCRIPTION:
        logger.debug("%s: no board description in this image: an Uno", link.name)
        return UNO_R3
    first = await link.request(p.ReadBoardDescription(0))
    width = (first.digital_pins + first.analog_pins + 7) // 8
    if width == 0 or len(first.maps) < width:
        raise ProtocolError(f"{link.name}: a board description without a whole pin map")
    per_page = len(first.maps) // width
    pages = -(-first.functions // per_page)
    replies = [first]
    for index in range(1, pages):
        # one at a time: a handful of round trips at open, and a page's reply is
        # checked against the first page's head before the next is asked for
        reply = await link.request(p.ReadBoardDescription(index))
        head = (reply.model, reply.digital_pins, reply.analog_pins, reply.functions)
        if head != (first.model, first.digital_pins, first.analog_pins, first.functions):
            raise ProtocolError(f"{link.name}: board description pages disagree on the board")
        replies.append(reply)
    maps = b"".join(r.maps for r in replies)
    chunks = [maps[i : i + width] for i in range(0, len(maps), width)]
    model = model_from_pages(first.model, first.digital_pins, first.analog_pins, chunks)
    logger.debug("%s: %s (%s)", link.name, model.name, model.mcu)
    return model
