"""Quadrature encoders on the virtual Uno.

Every oracle is the harness's quadrature generator (firmware/sim/quadrature.c): its
position in quarter steps, the double steps it injected, the simulated time of its edges;
never the library's own answer.  The long soak (10**6 edges at the highest rate) is
``python -m benchmarks.sensors_encoders``; these runs take seconds.
"""

from __future__ import annotations

import io

import anyio
import anyio.from_thread
import anyio.to_thread
import pytest
from rich.console import Console

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D12, blocking
from arduinoio_async.board import Board
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import PinRoleError
from arduinoio_async.sim import QuadratureGenerator, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


def truth(generators: list[QuadratureGenerator], a: int) -> QuadratureGenerator:
    """The generator whose pin A is ``a``."""
    return next(g for g in generators if g.a == a)


def floor_div(x: int, d: int) -> int:
    return x // d  # Python floors, as the board's x1/x2 counting does (encoder.c)


async def start_low(uno: VirtualUno, *pins: str) -> None:
    """Hold the pins low before the encoder takes them (its pull-ups would lift them)."""
    for pin in pins:
        await uno.drive(pin, 0)


async def test_counts_exact_with_reversals(virtual_uno_factory: VirtualUnoFactory) -> None:
    """Two encoders (INT0/INT1 and pin-change pins) count every edge of 20,000 each with
    random reversals and jitter, at 10,000 edges/s each: board count == generator position
    (the ceiling is the benchmark's: python -m benchmarks.sensors_encoders)."""
    uno = await virtual_uno_factory(baud=1_000_000)
    await start_low(uno, "D2", "D3", "D4", "D12")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        left = await board.encoder(a=D2, b=D3)
        right = await board.encoder(a=D4, b=D12, mode="x4")
        assert (left.slot, right.slot) == (0, 1)
        await uno.quadrature("D2", "D3", edges=20_000, rate=10_000, reverse=0.02, jitter=0.2)
        await uno.quadrature(
            "D4", "D12", edges=20_000, rate=10_000, reverse=0.05, jitter=0.2, seed=5
        )
        generators = await uno.wait_quadrature()
        for handle, pin in ((left, 2), (right, 4)):
            g = truth(generators, pin)
            state = await handle.read()
            assert g.reversals > 100 and g.skips == 0
            assert (state.count, state.invalid) == (g.position, 0), g


async def test_injected_invalid_transition_is_counted(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """A double step (both pins at once) is counted as invalid, and the count still
    follows the generator (the step went the last direction's way)."""
    uno = await virtual_uno_factory(baud=1_000_000)
    await start_low(uno, "D5", "D7")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        enc = await board.encoder(a=D5, b=D7)
        await uno.quadrature("D5", "D7", edges=2_000, rate=5_000, skip_every=250)
        g = truth(await uno.wait_quadrature(), 5)
        state = await enc.read()
        assert g.skips >= 5
        assert (state.count, state.invalid) == (g.position, g.skips)


async def test_modes_scale(virtual_uno_factory: VirtualUnoFactory) -> None:
    """x1, x2 and x4 on one generator each: whole cycles, edges of A, every edge."""
    uno = await virtual_uno_factory(baud=1_000_000)
    await start_low(uno, "D2", "D3", "D4", "D5", "D8", "D9")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        x1 = await board.encoder(a=D2, b=D3, mode="x1")
        x2 = await board.encoder(a=D4, b=D5, mode="x2")
        x4 = await board.encoder(a=D8, b=D9, mode=4)
        for a, b, seed in (("D2", "D3", 1), ("D4", "D5", 2), ("D8", "D9", 3)):
            await uno.quadrature(a, b, edges=4_003, rate=10_000, reverse=0.01, seed=seed)
        generators = await uno.wait_quadrature()
        assert await x1.count() == floor_div(truth(generators, 2).position + 3, 4)
        assert await x2.count() == floor_div(truth(generators, 4).position + 1, 2)
        assert await x4.count() == truth(generators, 8).position


async def test_stream_reports_preset_and_velocity(virtual_uno_factory: VirtualUnoFactory) -> None:
    """The stream carries the counts, reports come every N counts, preset replaces the
    count atomically, and the edge times give the generator's rate."""
    uno = await virtual_uno_factory(baud=1_000_000)
    await start_low(uno, "D2", "D3")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        enc = await board.encoder(a=D2, b=D3)
        before = await enc.read()
        async with (
            enc.reports(every=100) as reports,
            board.stream(encoders=True, period_ms=1) as samples,
        ):
            await uno.quadrature("D2", "D3", edges=3_000, rate=10_000)
            got = []
            async for state in reports:
                got.append(state)
                if len(got) == 30:
                    break
            g = truth(await uno.wait_quadrature(), 2)
            last = None
            async for sample in samples:
                assert sample.encoders is not None
                last = sample.encoders[0]
                if last == g.position:
                    break
        # sent by the board's main loop, which sees every edge's interrupt end: a report
        # comes at the 100th count moved, or the edge after it
        steps = [b.count - a.count for a, b in zip([before, *got], got, strict=False)]
        assert all(100 <= step <= 102 for step in steps), steps
        assert reports.missed == 0
        after = await enc.read()
        assert after.count == g.position == 3_000
        # 3,000 edges at 10,000/s: 2,999 intervals of 100 us between the first and last
        velocity = after.velocity_since(got[0])
        assert velocity == pytest.approx(10_000, rel=1e-3)
        assert before.edge_us == 0
        old = await enc.preset(-5)
        assert old.count == 3_000
        await uno.quadrature("D2", "D3", edges=7, rate=10_000, direction=-1)
        await uno.wait_quadrature()
        assert await enc.count() == -12


async def test_pin_roles_name_the_other_user(virtual_uno_factory: VirtualUnoFactory) -> None:
    """A pin held by a counter or by another encoder is refused before anything is sent;
    releasing one pin frees both."""
    uno = await virtual_uno_factory(baud=1_000_000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.counter(D2)
        with pytest.raises(PinRoleError, match="event counter"):
            await board.encoder(a=D2, b=D4)
        enc = await board.encoder(a=D4, b=D5)
        with pytest.raises(PinRoleError, match="quadrature encoder"):
            await board.encoder(a=D7, b=D5)
        await board.release(D5)
        assert enc.released
        again = await board.encoder(a=D4, b=D5)
        assert again.slot == 0
        with anyio.fail_after(5):
            await again.read()


async def test_cli_and_blocking_api(virtual_uno_factory: VirtualUnoFactory) -> None:
    """``arduinoio encoder`` prints the count and frees both pins; the blocking twin counts
    what the generator drove."""
    uno = await virtual_uno_factory(baud=1_000_000)
    await start_low(uno, "D6", "D7")
    buffer = io.StringIO()
    argv = ["encoder", "D6", "D7", "--seconds", "0.4", "--interval", "0.2"]
    argv += ["--port", uno.port, "--baud", str(uno.baud)]
    code = await anyio.to_thread.run_sync(
        lambda: cli_main(argv, console=Console(file=buffer, width=200))
    )
    out = buffer.getvalue()
    assert code == 0, out
    assert "encoder D6/D7 x4: count 0" in out and out.count("invalid 0") == 2

    def script() -> tuple[int, int]:
        with blocking.open_board(uno.port, baudrate=uno.baud) as board:
            enc = board.encoder(D6, D7, mode="x2")  # the CLI released both pins
            anyio.from_thread.run(lambda: uno.quadrature("D6", "D7", edges=501, rate=5_000))
            position = anyio.from_thread.run(uno.wait_quadrature)[0].position
            return enc.count(), position

    count, position = await anyio.to_thread.run_sync(script)
    assert count == floor_div(position + 1, 2)
