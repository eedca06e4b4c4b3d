"""HC-SR04 style sonars (SONAR) on the virtual Uno's sensing image.

The oracle is the harness's sonar model (firmware/sim/sonar_model.c): the distance it is
set to, the echo widths it drove (in CPU cycles), the triggers it saw and whether one came
while another sonar's measurement ran (an overlap: sonars that can hear each other).
"""

from __future__ import annotations

import io

import anyio
import anyio.from_thread
import anyio.to_thread
import pytest
from rich.console import Console

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11, D12, D13, blocking
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.sonars import Sonar, SonarReading
from arduinoio_async.cli import main as cli_main
from arduinoio_async.errors import (
    FirmwareFeatureError,
    PinCapabilityError,
    PinRoleError,
    UsageError,
    ValueRangeError,
)
from arduinoio_async.sim import SonarModel, VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

pytestmark = pytest.mark.sim


def within(distance_mm: int | None, truth_mm: float) -> bool:
    """The board's distance within 1 % or 3 mm of the model's (the issue's bound)."""
    return distance_mm is not None and abs(distance_mm - truth_mm) <= max(3.0, truth_mm / 100)


async def model(uno: VirtualUno, trigger: int) -> SonarModel:
    return (await uno.sonar_status()).on(trigger)


async def settled(uno: VirtualUno, sonar: Sonar) -> tuple[SonarReading, SonarModel]:
    """A reading taken after the model has answered two more firings of ``sonar`` (the
    first may have started before the model's distance changed), with the model's state
    from just before the read (the same distance: nothing moved since)."""
    trigger = int(sonar.pin)
    start = await model(uno, trigger)
    done = start.echoes + start.no_echoes
    with anyio.fail_after(10):
        while True:
            now = await model(uno, trigger)
            if now.echoes + now.no_echoes >= done + 2 and not now.busy:
                reading = await sonar.read()
                if reading.age_ms < 20:  # the board took the model's last echo
                    return reading, now
            await anyio.sleep(0.005)


async def test_distances_match_the_model_within_1_percent_or_3_mm(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D7", "D8", distance_mm=1000)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        sonar = await board.sonar(D7, D8)
        await board.sonar_timing(period_ms=35)
        errors = []
        for distance in (20, 100, 333, 1000, 2000, 3900):
            await uno.sonar("D7", distance_mm=distance)
            reading, truth = await settled(uno, sonar)
            assert truth.distance_mm == distance
            assert not reading.no_echo
            assert within(reading.distance_mm, distance), (reading, distance)
            assert abs(reading.echo_us - truth.last_echo_us) <= 2, (reading, truth)
            assert reading.distance_mm is not None
            errors.append(abs(reading.distance_mm - distance))
        truth = await model(uno, 7)
        assert truth.short_triggers == 0 and truth.ignored == 0
        assert all(t.width_us >= 10 for t in truth.log)


async def test_no_echo_is_its_own_answer_and_a_distance_comes_back(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """Nothing in range: the part holds its echo for 38 ms; the board gives up at 30 ms
    and says "no echo" (no distance, never the last one); then an object comes back."""
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D4", "D5", distance_mm=0)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        sonar = await board.sonar(D4, D5)
        first = await sonar.read()
        assert first.distance_mm is None  # not fired yet, or nothing heard: never a distance
        reading, truth = await settled(uno, sonar)
        assert truth.no_echoes >= 2 and truth.echoes == 0
        assert reading.no_echo and reading.distance_mm is None and reading.echo_us == 0
        assert await sonar.distance_mm() is None
        await uno.sonar("D4", distance_mm=5000)  # beyond the part's 4 m: no echo either
        reading, _ = await settled(uno, sonar)
        assert reading.no_echo
        await uno.sonar("D4", distance_mm=750)
        reading, truth = await settled(uno, sonar)
        assert not reading.no_echo and within(reading.distance_mm, 750)
        assert truth.echoes >= 1


async def test_four_sonars_fire_in_turn_and_never_overlap(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    """With a 1 ms period the next sonar would fire at once: the board still waits for
    the echo under way to end (or time out), so the model never sees a trigger while
    another sonar's measurement runs; each sonar's own distance comes back."""
    uno = await virtual_uno_factory(profile="sensing")
    pins = [(D2, D3, 300), (D4, D5, 0), (D6, D7, 1500), (D8, D9, 50)]
    for trigger, echo, distance in pins:
        await uno.sonar(int(trigger), int(echo), distance_mm=distance)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        sonars = [await board.sonar(t, e) for t, e, _ in pins]
        assert [s.slot for s in sonars] == [0, 1, 2, 3]
        await board.sonar_timing(period_ms=1)
        with anyio.fail_after(20):
            while True:
                status = await uno.sonar_status()
                if min(s.triggers for s in status.sonars) >= 8:
                    break
                await anyio.sleep(0.02)
        assert status.overlaps == 0
        for sonar, (_, _, distance) in zip(sonars, pins, strict=True):
            truth = status.on(int(sonar.pin))
            assert truth.ignored == 0 and truth.short_triggers == 0
            reading = await sonar.read()
            if distance:
                assert within(reading.distance_mm, distance), (sonar, reading)
            else:
                assert reading.no_echo
        # in turn: the triggers, merged by time, go 0, 1, 2, 3, 0, 1, ...
        fired = sorted(
            (t.at_us, int(s.trigger)) for s in status.sonars for t in s.log if t.echo_us >= 0
        )
        order = [trigger for _, trigger in fired]
        cycle = [int(t) for t, _, _ in pins]
        start = order.index(cycle[0])
        expected = [cycle[i % 4] for i in range(len(order) - start)]
        assert order[start:] == expected


async def test_the_stream_carries_each_sonars_latest_reading(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D10", "D11", distance_mm=420)
    await uno.sonar("D12", "D13", distance_mm=0)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        near = await board.sonar(D10, D11)
        far = await board.sonar(D12, D13)
        await board.sonar_timing(period_ms=20)
        await settled(uno, far)
        async with board.stream(sonars=True, encoders=True, period_ms=5) as samples:
            seen = []
            async for sample in samples:
                assert sample.sonars is not None and len(sample.sonars) == 2
                seen.append(sample.sonars)
                if len(seen) == 40:
                    break
        assert samples.gaps == 0
        for near_sample, far_sample in seen:
            assert within(near_sample.distance_mm, 420)
            assert far_sample.no_echo and far_sample.distance_mm is None
            # each sonar fires every 2 x 20 ms; 30 ms is the longest wait for a reading
            assert near_sample.age_ms is not None and near_sample.age_ms < 75
        assert near.slot == 0 and far.slot == 1


async def test_many_tasks_read_at_once(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    await uno.sonar("D7", "D8", distance_mm=1234)
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        sonar = await board.sonar(D7, D8)
        await settled(uno, sonar)
        readings: list[SonarReading] = []

        async def reader() -> None:
            for _ in range(5):
                readings.append(await sonar.read())

        async with anyio.create_task_group() as tg:
            for _ in range(24):
                tg.start_soon(reader)
        assert len(readings) == 120
        assert all(within(r.distance_mm, 1234) for r in readings)


async def test_pins_and_arguments_are_refused_before_anything_is_sent(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(profile="sensing")
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        await board.encoder(D2, D3)
        with pytest.raises(PinRoleError, match="quadrature encoder"):
            await board.sonar(D4, D3)
        sonar = await board.sonar(D4, D5)
        with pytest.raises(PinRoleError, match="sonar echo"):
            await board.encoder(D5, D6)
        with pytest.raises(PinRoleError, match="sonar trigger"):
            await board.pulse_input(D4)
        with pytest.raises(ValueRangeError, match="other than the trigger"):
            await board.sonar(D6, D6)
        with pytest.raises(PinCapabilityError):
            await board.sonar(D6, 7)  # type: ignore[arg-type]
        with pytest.raises(ValueRangeError):
            await board.sonar(D6, D7, slot=4)
        with pytest.raises(UsageError, match="in use"):
            await board.sonar(D6, D7, slot=0)
        for bad in ({"period_ms": 0}, {"speed_m_s": 200.0}, {"temperature_c": 300.0}):
            with pytest.raises(ValueRangeError):
                await board.sonar_timing(**bad)
        # the board refuses what the library would: a raw CONFIG on a held pin
        with pytest.raises(Exception) as busy:
            await board.request(p.SonarConfig(slot=1, trigger=6, echo=3))
        assert getattr(busy.value, "code", None) == p.ErrorCode.PIN_BUSY
        await sonar.release()
        await board.sonar(D5, D4)  # both pins free again


async def test_an_image_without_sonars_says_which_has_them(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory()
    async with Board.open(uno.port, baudrate=uno.baud) as board:
        with pytest.raises(FirmwareFeatureError, match="sensing"):
            await board.sonar(D7, D8)
        assert D7 not in board.roles


async def test_cli_and_blocking_api(virtual_uno_factory: VirtualUnoFactory) -> None:
    """``arduinoio sonar`` prints the model's distance and frees both pins; the blocking
    twin reads it too."""
    uno = await virtual_uno_factory(profile="sensing", baud=1_000_000)
    await uno.sonar("D7", "D8", distance_mm=612)
    buffer = io.StringIO()
    argv = ["sonar", "D7", "D8", "--seconds", "0.4", "--interval", "0.2", "--period-ms", "20"]
    argv += ["--port", uno.port, "--baud", str(uno.baud)]
    code = await anyio.to_thread.run_sync(
        lambda: cli_main(argv, console=Console(file=buffer, width=200))
    )
    out = buffer.getvalue()
    assert code == 0, out
    assert "sonar D7/D8: every 20 ms" in out
    distances = [int(word) for line in out.splitlines()[1:] for word in line.split()[:1]]
    assert len(distances) == 2 and all(within(d, 612) for d in distances), out

    def script() -> int | None:
        with blocking.open_board(uno.port, baudrate=uno.baud) as board:
            sonar = board.sonar(D7, D8)  # the CLI released both pins
            board.sonar_timing(period_ms=20)
            deadline = 200
            while sonar.read().readings < 2 and deadline:
                deadline -= 1
                anyio.from_thread.run(anyio.sleep, 0.01)
            return sonar.distance_mm()

    assert within(await anyio.to_thread.run_sync(script), 612)
