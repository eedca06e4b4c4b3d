"""The pulse input handle against the FakeBoard's PULSE_IN model: no simulator, milliseconds.

The model (``testing/_fake_pulse_in.py``) times the pulses a test gives it
(``fake.rc_pulse(pin, width_us)``, or two ``drive()`` calls timed by the fake's clock) as
pulse_in.c does: the last width, its age, lost after the timeout, "back" on the first pulse.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D5, D7
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.cli._roles import pin_roles
from arduinoio_async.errors import BoardError, PinRoleError
from arduinoio_async.testing import FakeBoard


async def test_the_fake_times_pulses_reports_loss_and_holds_the_pin() -> None:
    async with FakeBoard() as fake, Board.connect(fake.host_stream) as board:
        signals: list[p.PulseInSignal] = []
        back = anyio.Event()

        def on_event(event: p.Event) -> None:
            if isinstance(event, p.PulseInSignal):
                signals.append(event)
                back.set()

        board.link.subscribe(on_event)
        rc = await board.pulse_input(D7, timeout_ms=40)
        first = await rc.read()
        assert (first.width_us, first.age_ms, first.lost) == (0, 65535, True)
        fake.rc_pulse(7, 1600)
        state = await rc.read()
        assert state.width_us == 1600 and not state.lost and state.age_ms < 40
        assert await rc.throttle() == pytest.approx(0.6)
        with anyio.fail_after(5):
            await back.wait()
        assert signals[0].slot == 0 and signals[0].lost == 0 and signals[0].width_us == 1600
        assert (await pin_roles(board)).get("D7") == "pulse-width input"
        with pytest.raises(PinRoleError, match="pulse-width input"):
            await board.pulse_input(D7)
        with pytest.raises(BoardError) as busy:  # the board refuses it too (raw request)
            await board.request(p.PulseInConfig(slot=1, pin=7, timeout_ms=10))
        assert busy.value.code is p.ErrorCode.PIN_BUSY
        with anyio.fail_after(5):
            while True:  # the timeout passes on the fake's clock
                if (await rc.read()).lost:
                    break
                await anyio.sleep(0.01)
        assert (await rc.read()).width_us == 1600
        await rc.release()
        assert "D7" not in await pin_roles(board)
        other = await board.pulse_input(D5, timeout_ms=100)
        fake.drive(5, True)
        await anyio.sleep(0.002)
        fake.drive(5, False)
        assert 2000 <= (await other.read()).width_us < 100_000
