"""RC widths within 2 us of the source while an encoder interrupts (issue 27 item 4).

Oracle: the harness's RC pulse source (firmware/sim/rcpulse.c, ``last_width_us`` in CPU
cycles).  The load is the benchmark's (benchmarks/sensors_pulse.py): pulse inputs on D4
and D8 beside an encoder on D2/D3 whose INT0/INT1 vectors delay a pin-change stamp by
up to ~300 cycles.  D8 is ICP1, the pin a hardware-capture path would stamp at the edge.

Status: fails today (the pin-change path is the only path; 12 us worst over 404 reads in
benchmarks/results/sensors.json).  Marked xfail, not strict: a run in which no encoder
edge happens to meet a pulse edge passes by chance (about 1 in 80 runs: each pulse meets
an edge with a probability of about 10 %), and a strict marker would then fail the suite.
The marker comes off when the capture path lands.
"""

from __future__ import annotations

import anyio
import pytest

from arduinoio_async import D2, D3, D4, D8
from arduinoio_async.board import Board
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


@pytest.mark.xfail(
    strict=False,
    reason="pin-change stamps run late behind INT0/INT1 (up to 12 us); the ICP1 capture "
    "path on D8 is not implemented yet (w5-rc)",
)
async def test_d8_widths_within_2_us_with_an_encoder_running(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        rc = await board.pulse_input(D8, timeout_ms=100)
        beside = await board.pulse_input(D4, timeout_ms=100)
        await uno.drive("D2", 0)
        await uno.drive("D3", 0)
        await board.encoder(D2, D3)
        await uno.quadrature("D2", "D3", edges=10**7, rate=5_000, reverse=0.01, jitter=0.2)
        errors: list[tuple[int, float]] = []
        for width in range(1000, 2001, 25):
            await uno.rcpulse("D8", width_us=width, period_us=20_000)
            await uno.rcpulse("D4", width_us=min(2000, width + 7), period_us=20_000)
            start = {s.pin: s.pulses for s in await uno.rcpulse_status()}
            with anyio.fail_after(30):
                while True:  # the harness's state, polled: no event to wait on
                    sources = await uno.rcpulse_status()
                    if all(s.pulses >= start[s.pin] + 2 for s in sources):
                        break
                    await anyio.sleep(0.005)
            state = await rc.read()
            truth = next(s for s in await uno.rcpulse_status() if s.pin == int(D8))
            assert state.width_us is not None and not state.lost
            errors.append((width, state.width_us - truth.last_width_us))
        assert (await beside.read()).width_us is not None
        await uno.rcpulse_stop()
        await uno.quadrature_stop()
        worst = max(errors, key=lambda e: abs(e[1]))
        assert abs(worst[1]) <= 2, f"worst {worst} over {len(errors)} reads"
