"""The failsafe on the virtual Uno: the board makes outputs safe when the host goes silent."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import anyio
import pytest

from arduinoio_async import D2, D4, D9, FailsafeTrippedError
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.manager import BoardManager, ManagerEvent
from arduinoio_async.sim import VirtualUno
from arduinoio_async.sim.pytest_plugin import VirtualUnoFactory

from .pulses import fresh_pulses

pytestmark = pytest.mark.sim

TIMEOUT_MS = 100


async def wait_pulse_width(uno: VirtualUno, pin: str, width: float, within: float) -> None:
    """Wait until the fixture captures pulses of ``width`` (or none, for 0) on ``pin``."""
    await uno.clear_pulse_stats(pin)
    with anyio.fail_after(within):
        while True:
            await anyio.sleep(0.045)
            stats = await uno.pulse_stats(pin)
            if width == 0 and not stats.high_us and stats.level == 0:
                return
            if stats.high_us and abs(stats.high_us[-1] - width) <= 1:
                return
            await uno.clear_pulse_stats(pin)


async def arm(board: Board) -> None:
    led = await board.digital_output(D4, initial=True)
    motor = await board.servo(D9, pulse_us=1500)
    wheel = await board.soft_pwm(D2, pulse_us=1800)
    await board.arm_failsafe(TIMEOUT_MS, {led: False, motor: 1000, wheel: 0})


async def assert_safe(uno: VirtualUno) -> None:
    with anyio.fail_after(1):
        while (await uno.pin("D4")).level != 0:  # noqa: ASYNC110 - state of another process
            await anyio.sleep(0.01)
    await wait_pulse_width(uno, "D9", 1000, within=1)
    await wait_pulse_width(uno, "D2", 0, within=1)


async def check_reaction_time(uno: VirtualUno) -> float:
    """The fixture's view: outputs safe within timeout + 5 ms of the host's last byte.

    Returns the measured reaction (ms) of the digital output, for the record.
    """
    silent_from = float((await uno.status())["last_host_byte_us"])
    limit = silent_from + (TIMEOUT_MS + 5) * 1000
    led = await uno.pulse_stats("D4")
    assert led.last_edge_us is not None and silent_from < led.last_edge_us <= limit
    for pin, safe in (("D9", 1000), ("D2", 0)):
        stats = await uno.pulse_stats(pin)
        later = [h for h, rise in zip(stats.high_us, stats.rise_us, strict=True) if rise > limit]
        assert all(abs(h - safe) <= 1 for h in later), (pin, stats)
    return (led.last_edge_us - silent_from) / 1000


async def test_a_blocked_event_loop_trips_the_failsafe(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with Board.open(uno.port) as board:
        fired: list[Board] = []
        board.on_failsafe(fired.append)
        await arm(board)
        assert (await uno.pin("D4")).level == 1
        time.sleep(0.3)  # noqa: ASYNC251 - the host's event loop is stuck: no heartbeat
        reaction = await check_reaction_time(uno)
        print(f"\nfailsafe reaction, blocked event loop: {reaction:.2f} ms (timeout {TIMEOUT_MS})")
        await assert_safe(uno)
        with pytest.raises(FailsafeTrippedError):
            await board.request(p.GpioWrite(4, True))
        assert fired == [board]
        assert (await board.status()).flags & p.StatusFlags.FAILSAFE_TRIPPED
        await board.rearm_failsafe(restore=True)
        assert (await uno.pin("D4")).level == 1
        assert not (await board.status()).flags & p.StatusFlags.FAILSAFE_TRIPPED


async def test_a_killed_client_process_trips_the_failsafe(
    virtual_uno_factory: VirtualUnoFactory, tmp_path: Path
) -> None:
    uno = await virtual_uno_factory(board_id=1)
    script = tmp_path / "client.py"
    script.write_text(
        "import sys, anyio\n"
        "from arduinoio_async.board import Board\n"
        "from arduinoio_async import D2, D4, D9\n"
        "async def main():\n"
        "    async with Board.open(sys.argv[1]) as board:\n"
        "        led = await board.digital_output(D4, initial=True)\n"
        "        motor = await board.servo(D9, pulse_us=1500)\n"
        "        wheel = await board.soft_pwm(D2, pulse_us=1800)\n"
        f"        await board.arm_failsafe({TIMEOUT_MS}, {{led: False, motor: 1000, wheel: 0}})\n"
        "        print('armed', flush=True)\n"
        "        await anyio.sleep_forever()\n"
        "anyio.run(main)\n"
    )
    client = subprocess.Popen(  # noqa: ASYNC220 - killed with SIGKILL below
        [sys.executable, str(script), uno.port], stdout=subprocess.PIPE, text=True
    )
    try:
        assert client.stdout is not None
        line = await anyio.to_thread.run_sync(client.stdout.readline)
        assert line.strip() == "armed"
        await anyio.sleep(0.5)  # alive and idle: the heartbeat keeps the outputs on
        assert (await uno.pin("D4")).level == 1
        client.send_signal(signal.SIGKILL)
    finally:
        client.kill()
        client.wait()
    await assert_safe(uno)
    await fresh_pulses(uno, "D9", 2)  # servo periods after the trip
    reaction = await check_reaction_time(uno)
    print(f"\nfailsafe reaction, killed process: {reaction:.2f} ms (timeout {TIMEOUT_MS})")


async def test_a_healthy_idle_client_never_trips(virtual_uno_factory: VirtualUnoFactory) -> None:
    uno = await virtual_uno_factory(board_id=1)
    async with Board.open(uno.port) as board:
        fired: list[Board] = []
        board.on_failsafe(fired.append)
        await arm(board)
        await anyio.sleep(10)
        assert not fired
        status = await board.status()
        assert status.flags & p.StatusFlags.FAILSAFE_ARMED
        assert not status.flags & p.StatusFlags.FAILSAFE_TRIPPED
        assert (await uno.pin("D4")).level == 1


async def test_the_manager_rearms_and_restores_after_a_trip(
    virtual_uno_factory: VirtualUnoFactory,
) -> None:
    uno = await virtual_uno_factory(board_id=6)
    events: list[ManagerEvent] = []
    async with BoardManager(ports=[uno.port], usb=False, env=False) as boards:
        boards.subscribe(events.append)
        board = await boards.get(6)
        await arm(board)
        time.sleep(0.3)  # noqa: ASYNC251 - block the event loop on purpose
        with anyio.fail_after(3):
            while not any(e.kind == "failsafe" for e in events):  # noqa: ASYNC110
                await anyio.sleep(0.02)
            while (await uno.pin("D4")).level != 1:  # noqa: ASYNC110
                await anyio.sleep(0.02)
        await board.request(p.GpioWrite(4, False))
        assert (await uno.pin("D4")).level == 0
