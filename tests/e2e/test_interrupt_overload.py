"""Edges faster than the board can take them cost samples and time, never the board.

An encoder driven past what the CPU can decode (or noise on its pins) keeps the pin
interrupts busy all the time.  The stream timer enables interrupts for its sample; under
such a load each new period nested inside the last until the stack ran into the
variables: at 80,000 edges/s over two encoders with a 1 kHz stream and pipelined writes
the virtual Uno crashed ("avr_sadly_crashed", SP 0x3A1) within 0.1 s.  Now a period that
comes while the last one's sample runs is counted and taken after it (hal_avr.c).  The
oracle is the harness: the CPU's state, the generators' positions.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import A0, A1, A2, A3, D2, D3, D8, D9, D13
from arduinoio_async.board import Board
from arduinoio_async.errors import LinkError
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def test_encoders_past_the_cpu_do_not_crash_the_board(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    for pin in ("D2", "D3", "D8", "D9"):
        await uno.drive(pin, 0)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        encoders = [await board.encoder(a=D2, b=D3), await board.encoder(a=D8, b=D9)]
        led = await board.digital_output(D13)
        answered = failed = 0

        async def write(level: bool) -> None:
            nonlocal answered, failed
            try:
                await led.write(level)
                answered += 1
            except LinkError:
                failed += 1  # the board had no time to answer: allowed, a crash is not

        async with (
            board.stream(analog=[A0, A1, A2, A3], encoders=True, period_ms=1) as stream,
            anyio.create_task_group() as writers,
        ):
            # 40,000 edges/s each with the stream and pipelined writes: more than the
            # CPU can decode (it crashed the board)
            await uno.quadrature("D2", "D3", edges=40_000, rate=40_000, jitter=0.2)
            await uno.quadrature("D8", "D9", edges=40_000, rate=40_000, jitter=0.2, seed=2)
            for i in range(64):
                writers.start_soon(write, bool(i & 1))
            generators = await uno.wait_quadrature(timeout=20)
            status = await uno.command("status")
            assert status["state"] in ("running", "sleeping"), status
            # the board answers and its stream goes on after the storm
            await board.read_id()
            seen = 0
            with anyio.fail_after(10):
                async for _ in stream:
                    seen += 1
                    if seen >= 50:
                        break
        assert answered + failed == 64
        for enc, g in zip(encoders, sorted(generators, key=lambda g: g.a), strict=True):
            state = await enc.read()
            # a state the board could not see in time is counted, not hidden
            assert state.count == g.position or state.invalid > 0, (state, g)
