"""RC pulse-width inputs (PULSE_IN) on the virtual Uno's sensing image.

The oracle is the harness's RC pulse source (firmware/sim/rcpulse.c): the width it held
the pin high, in CPU cycles, and whether it is still pulsing.  The requests go as raw
PULSE_IN frames (the typed handle is not written yet: docs in notes/i27-pulse.md).
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D4, D5, D8
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.errors import BoardError, PinRoleError
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def read_after_pulse(
    board: Board, slot: int, after: int, uno: VirtualUno
) -> p.PulseInReadReply:
    """The slot's state once the source has completed more than ``after`` pulses and
    the board's main loop has taken the last one (its age under a period)."""
    with anyio.fail_after(10):
        while True:
            sources = await uno.rcpulse_status()
            if sources[0].pulses > after:
                reply = await board.request(p.PulseInRead(slot=slot))
                if reply.age_ms < 15:
                    return reply
            await anyio.sleep(0.005)


async def test_widths_across_the_rc_range_loss_and_return(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        send, received = anyio.create_memory_object_stream[p.PulseInSignal](16)
        board.link.subscribe(
            lambda e: send.send_nowait(e) if isinstance(e, p.PulseInSignal) else None
        )
        await board.request(p.PulseInConfig(slot=2, pin=7, timeout_ms=60))
        errors = []
        for width in (1000, 1250, 1500, 1750, 2000, 1111):
            await uno.rcpulse("D7", width_us=width, period_us=20_000)
            before = (await uno.rcpulse_status())[0].pulses
            reply = await read_after_pulse(board, 2, before + 1, uno)
            truth = (await uno.rcpulse_status())[0]
            assert truth.width_us == width
            errors.append(abs(reply.width_us - truth.width_us))
            assert reply.lost == 0
        assert max(errors) <= 2, errors
        with anyio.fail_after(10):
            back = await received.receive()  # at the first pulse after CONFIG
        assert back.slot == 2 and back.lost == 0
        await uno.rcpulse_stop("D7")
        with anyio.fail_after(10):
            lost = await received.receive()
        assert lost.lost == 1 and abs(lost.width_us - 1111) <= 2  # the last width, as measured
        assert (await board.request(p.PulseInRead(slot=2))).lost == 1
        await uno.rcpulse("D7", width_us=1400)
        with anyio.fail_after(10):
            again = await received.receive()
        assert again.lost == 0 and abs(again.width_us - 1400) <= 2


async def test_a_pulse_input_refuses_a_pin_another_role_holds(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.request(p.EncoderConfig(slot=0, pin_a=4, pin_b=5, mode=p.EncoderMode.X4))
        with pytest.raises(BoardError) as busy:
            await board.request(p.PulseInConfig(slot=0, pin=5, timeout_ms=100))
        assert busy.value.code == p.ErrorCode.PIN_BUSY


async def test_the_typed_handle_reads_positions_and_refuses_a_held_pin_by_name(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """board.pulse_input(): the width the source drives, as -1..1 and 0..1 by the end
    points; None while the signal is lost; a pin another role holds is refused before
    anything is sent, naming that role."""
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        rc = await board.pulse_input(D8, timeout_ms=60, low_us=1100, centre_us=1500, high_us=1900)
        assert rc.slot == 0
        assert await rc.position() is None  # no pulse yet: lost
        await uno.rcpulse("D8", width_us=1700)
        with anyio.fail_after(10):
            while True:
                state = await rc.read()
                if not state.lost:
                    break
                await anyio.sleep(0.005)
        truth = (await uno.rcpulse_status())[0]
        assert abs(state.width_us - truth.last_width_us) <= 2
        position = await rc.position()
        throttle = await rc.throttle()
        assert position is not None and abs(position - 0.5) <= 2 / 400
        assert throttle is not None and abs(throttle - 0.75) <= 2 / 800
        await board.encoder(D4, D5)
        with pytest.raises(PinRoleError, match="quadrature encoder"):
            await board.pulse_input(D5)
        await rc.release()
        await board.pulse_input(D8)  # free again
