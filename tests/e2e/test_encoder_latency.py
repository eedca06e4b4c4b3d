"""How long an encoder's edge waits for its interrupt, with the link busy.

An edge that waits longer than the next edge of the same encoder is a skipped state, so
the longest wait sets the encoders' rate limit.  The oracle is the harness's probe
(firmware/sim/quadrature.c ``max_irq_latency_us``): the simulated time from the cycle a
generator changed a pin to the cycle the CPU entered the vector that answers that pin,
and where the CPU was when the edge came.  Measured in simulated cycles, so the machine's
load does not move it.

Before the fix in ``hal_tx_publish`` (uart.c) a 1 kHz stream sample queued behind a
reply was moved with interrupts off: edges waited 43-62 us (the probe's place: that
loop).  The bound below is the path that remains: one encoder vector behind another,
the UART's and the timer's short vectors.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import A0, A1, A2, A3, D2, D3, D8, D9, D13
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim

#: The longest wait allowed (simulated us).  At 100,000 edges/s over two encoders with
#: 20 % jitter, an encoder's edges come 16 us apart at the closest.
MAX_WAIT_US = 25.0


async def test_edges_wait_briefly_for_their_vector_while_stream_and_writes_run(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(baud=1_000_000)
    for pin in ("D2", "D3", "D8", "D9"):
        await uno.drive(pin, 0)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        encoders = [await board.encoder(a=D2, b=D3), await board.encoder(a=D8, b=D9)]
        led = await board.digital_output(D13)
        stop = anyio.Event()

        async def hammer() -> None:
            while not stop.is_set():
                async with anyio.create_task_group() as tg:
                    for i in range(8):
                        tg.start_soon(led.write, bool(i & 1))

        async with (
            board.stream(analog=[A0, A1, A2, A3], encoders=True, period_ms=1) as stream,
            anyio.create_task_group() as tg,
        ):

            async def consume() -> None:
                async for _ in stream:
                    pass

            tg.start_soon(consume)
            tg.start_soon(hammer)
            await uno.quadrature("D2", "D3", edges=20_000, rate=20_000, reverse=0.01, jitter=0.2)
            await uno.quadrature(
                "D8", "D9", edges=20_000, rate=20_000, reverse=0.01, jitter=0.2, seed=2
            )
            generators = await uno.wait_quadrature(timeout=120)
            stop.set()
            tg.cancel_scope.cancel()
        for enc, g in zip(encoders, sorted(generators, key=lambda g: g.a), strict=True):
            state = await enc.read()
            assert state.count == g.position, g
            assert g.irq_latency_edges >= 19_000, g  # the probe saw (nearly) every edge
            assert 0 < g.max_irq_latency_us <= MAX_WAIT_US, (
                f"D{g.a}/D{g.b}: an edge waited {g.max_irq_latency_us} us for its vector "
                f"(CPU at byte address 0x{g.max_irq_latency_pc:x}, interrupts "
                f"{'on' if g.max_irq_latency_interrupts_on else 'off'})"
            )
