"""In-memory boards for testing robot code (and this library) without hardware.

:class:`FakeBoard` answers requests with the real protocol core over a memory link and
models every feature it advertises in its capabilities reply: pin roles of Table III,
levels, latched edges, analog values, an I2C memory device, counters by edge, servo and
software-PWM pulses, the board ID, status and session, firmware-timed streams and the
link failsafe.  :class:`Faults` makes it an unreliable peer.

    async with FakeBoard(board_id=0x0001) as fake:
        async with Board.connect(fake.host_stream) as board:
            await board.gpio(D2).write(True)
            assert fake.levels[2]
"""

from ._fake_board import FakeBoard
from ._fake_spi import FakeMcp3008
from ._faults import Faults

__all__ = ["FakeBoard", "FakeMcp3008", "Faults"]
