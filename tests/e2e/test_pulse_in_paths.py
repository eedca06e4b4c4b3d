"""RC pulse inputs on the other paths: the firmware-timed stream, many tasks at once.

Oracle: the harness's RC pulse sources (``uno.rcpulse_status``: the width each source
held its pin high, measured in CPU cycles), never the library's own answer.
"""

from __future__ import annotations

import io

import anyio
import anyio.from_thread
import anyio.to_thread
import pytest
from rich.console import Console

from arduinoio_async import A0, D2, D3, D4, D7, D8, D12, blocking
from arduinoio_async.board import Board
from arduinoio_async.board.pulse_inputs import PulseState
from arduinoio_async.cli import main as cli_main
from arduinoio_async.cli._roles import pin_roles
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


async def truth_of(uno: VirtualUno, pin: int) -> float:
    """The last completed pulse's width on ``pin`` by the harness."""
    return next(s for s in await uno.rcpulse_status() if s.pin == pin).last_width_us


async def test_the_stream_carries_each_slots_width_and_its_loss(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.pulse_input(D7, slot=0, timeout_ms=60)
        await board.pulse_input(D8, slot=2, timeout_ms=60)  # slot 1 has no input
        await uno.rcpulse("D7", width_us=1300, period_us=10_000)
        await uno.rcpulse("D8", width_us=1850, period_us=10_000)
        async with board.stream(analog=[A0], pulse_inputs=True, period_ms=5) as samples:
            with anyio.fail_after(20):
                async for s in samples:
                    assert s.pulse_widths is not None and s.pulse_lost is not None
                    assert len(s.pulse_widths) == 3 and s.pulse_lost[1]
                    if not s.pulse_lost[0] and not s.pulse_lost[2]:
                        break
            # once both sources settled, a sample's widths are the harness's last pulses
            with anyio.fail_after(20):
                async for s in samples:
                    assert s.pulse_widths is not None
                    if s.sequence % 8 == 0:
                        break
            assert s.pulse_widths is not None  # (the widths are constant: any pulse's)
            assert abs(s.pulse_widths[0] - await truth_of(uno, 7)) <= 2, s
            assert abs(s.pulse_widths[2] - await truth_of(uno, 8)) <= 2, s
            await uno.rcpulse_stop("D8")
            with anyio.fail_after(20):
                async for s in samples:
                    assert s.pulse_lost is not None and s.pulse_widths is not None
                    if s.pulse_lost[2]:
                        break
            assert s.pulse_lost is not None and s.pulse_widths is not None
            assert not s.pulse_lost[0]
            assert abs(s.pulse_widths[2] - 1850) <= 2  # the last width, marked lost


async def test_many_tasks_read_one_input_and_all_see_the_sources_width(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        rc = await board.pulse_input(D7, timeout_ms=100)
        await uno.rcpulse("D7", width_us=1620, period_us=10_000)
        with anyio.fail_after(20):
            while True:  # the first pulse reaches the board
                if not (await rc.read()).lost:
                    break
                await anyio.sleep(0.01)
        widths: list[int] = []

        async def reader() -> None:
            for _ in range(5):
                state = await rc.read()
                assert not state.lost
                widths.append(state.width_us)

        async with anyio.create_task_group() as tg:
            for _ in range(12):
                tg.start_soon(reader)
        truth = await truth_of(uno, 7)
        assert len(widths) == 60
        assert max(abs(w - truth) for w in widths) <= 2, (truth, sorted(set(widths)))


async def test_the_boards_pin_roles_name_a_pulse_input(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        rc = await board.pulse_input(D7)
        assert (await pin_roles(board)).get("D7") == "pulse-width input"
        await rc.release()
        assert "D7" not in await pin_roles(board)


async def test_cli_reads_and_watches_and_the_blocking_twin_reads(
    virtual_uno_factory: VirtualUnoFactory, capsys: pytest.CaptureFixture[str]
) -> None:
    """``arduinoio rc D7`` prints the source's width (and frees the pin), ``--seconds``
    watches; a bad pin is a one-line error; the blocking twin reads the same width."""
    uno = await virtual_uno_factory(profile="sensing")
    await uno.rcpulse("D7", width_us=1740, period_us=10_000)
    target = ["--port", uno.port, "--baud", str(uno.baud)]

    def cli(*argv: str) -> tuple[int, str]:
        buffer = io.StringIO()
        code = cli_main([*argv, *target], console=Console(file=buffer, width=200))
        return code, buffer.getvalue()

    code, out = await anyio.to_thread.run_sync(lambda: cli("rc", "D7"))
    assert code == 0, out
    truth = await truth_of(uno, 7)
    width = int(out.split("width ")[1].split(" us")[0])
    assert abs(width - truth) <= 2, out
    code, out = await anyio.to_thread.run_sync(
        lambda: cli("rc", "D7", "--seconds", "0.2", "--interval", "0.1")
    )
    assert code == 0 and out.count("width ") == 3, out
    capsys.readouterr()
    code, _ = await anyio.to_thread.run_sync(lambda: cli("pulse-in", "D7", "--timeout-ms", "0"))
    err = capsys.readouterr().err
    assert code != 0 and "timeout_ms" in err and len(err.strip().splitlines()) == 1, err

    def script() -> tuple[int, bool, float | None]:
        with blocking.open_board(uno.port, baudrate=uno.baud) as board:
            rc = board.pulse_input(D7, timeout_ms=100)  # the CLI released the pin
            state = rc.read()
            for _ in range(500):  # until the first pulse after set-up (a round trip each)
                if not state.lost:
                    break
                state = rc.read()
            return state.width_us, state.lost, rc.throttle()

    width, lost, throttle = await anyio.to_thread.run_sync(script)
    assert not lost and abs(width - truth) <= 2
    assert throttle is not None and abs(throttle - (truth - 1000) / 1000) < 0.01


async def test_an_encoder_counts_exactly_beside_four_pulse_inputs(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Four pulse inputs (a pin-change edge every ~250 us, each a longer vector run) beside
    an encoder on INT0/INT1 at 20,000 edges/s: the count stays exact (the generator's
    position), no invalid transition.  (Letting the pin-change vector nest in the encoder's
    vectors failed this: 268 invalid, notes/w4-rc.md.)"""
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        for pin in ("D2", "D3"):
            await uno.drive(pin, 0)
        enc = await board.encoder(D2, D3)
        inputs = [await board.pulse_input(pin, timeout_ms=100) for pin in (D4, D7, D8, D12)]
        for k, rc in enumerate(inputs):
            await uno.rcpulse(rc.pin.name, width_us=1100 + 150 * k, period_us=2_000)
        await uno.quadrature("D2", "D3", edges=40_000, rate=20_000, reverse=0.01, jitter=0.2)
        (truth,) = await uno.wait_quadrature()
        state = await enc.read()
        assert (state.count, state.invalid) == (truth.position, 0)
        for rc in inputs:
            assert not (await rc.read()).lost


async def test_on_signal_calls_back_on_return_and_on_loss(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """``rc.on_signal(callback)``: the board's PulseInSignal events of this input as
    PulseStates, "back" with the source's width, then "lost" once the source stops."""
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        other = await board.pulse_input(D8, timeout_ms=50)  # its events are not rc's
        rc = await board.pulse_input(D7, timeout_ms=50)
        send, received = anyio.create_memory_object_stream[PulseState](8)
        unsubscribe = rc.on_signal(send.send_nowait)
        await uno.rcpulse("D8", width_us=1900, period_us=10_000)
        await uno.rcpulse("D7", width_us=1200, period_us=10_000)
        with anyio.fail_after(10):
            back = await received.receive()
        assert not back.lost and abs(back.width_us - await truth_of(uno, 7)) <= 2
        await uno.rcpulse_stop("D7")
        with anyio.fail_after(10):
            lost = await received.receive()
        assert lost.lost and abs(lost.width_us - 1200) <= 2
        unsubscribe()
        assert not (await other.read()).lost
