"""The blocking facade (``arduinoio_async.blocking``) against a virtual Uno, from plain threads.

These tests are deliberately synchronous: they are what a script or a notebook does.  The
virtual Uno is started through a portal of the test's own.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from anyio.from_thread import start_blocking_portal

from arduinoio_async import (
    A0,
    D2,
    D3,
    D4,
    D5,
    D7,
    D8,
    D9,
    BoardDisconnectedError,
    PinCapabilityError,
)
from arduinoio_async import protocol as p
from arduinoio_async.blocking import connect, open_board
from arduinoio_async.sim import SimulatorNotAvailable, VirtualUno

from .pulses import control_now

pytestmark = pytest.mark.sim


@contextmanager
def virtual_uno(**options: object) -> Iterator[VirtualUno]:
    with start_blocking_portal() as portal:
        try:
            cm = portal.wrap_async_context_manager(VirtualUno(**options))  # type: ignore[arg-type]
            with cm as uno:
                yield uno
        except SimulatorNotAvailable as exc:
            if os.environ.get("ARDUINOIO_SIM_REQUIRED"):
                raise
            pytest.skip(f"virtual Uno not available: {exc}")


def test_a_script_drives_a_pin_and_reads_its_jumper() -> None:
    with virtual_uno(board_id=0x0031, fixture="loopback") as uno, open_board(uno.port) as board:
        assert board.board_id == 0x0031 and board.read_id() == 0x0031
        out = board.gpio(D2)
        seen = board.digital_input(D3)
        for level in (True, False, True):
            out.write(level)
            assert seen.read().level is level  # D2 is jumpered to D3
        with pytest.raises(PinCapabilityError):
            board.servo(D2)  # type: ignore[arg-type]  # D2 has no hardware servo PWM


def test_a_notebook_keeps_the_board_open_across_cells_until_it_closes_it() -> None:
    with virtual_uno(board_id=0x0032, fixture="loopback") as uno:
        board = connect(uno.port)  # cell 1
        try:
            led = board.digital_output(D4, initial=True)  # cell 2
            assert led.read() is True
            volts = board.analog(A0).read_volts()  # cell 3
            assert 0.0 <= volts <= 5.0
        finally:
            board.close()  # last cell
        board.close()  # closing twice is harmless
        with pytest.raises(BoardDisconnectedError):
            led.write(False)
        with open_board(uno.port) as again:  # the port was released
            assert again.read_id() == 0x0032


def test_samples_of_a_stream_as_a_plain_iterator() -> None:
    with virtual_uno(board_id=0x0033) as uno, open_board(uno.port) as board:
        with board.stream(analog=[A0], period_ms=5) as samples:
            sequences = [sample.sequence for sample, _ in zip(samples, range(10), strict=False)]
        assert sequences == list(range(sequences[0], sequences[0] + 10))
        assert samples.gaps == 0


def test_an_idle_script_still_feeds_an_armed_failsafe() -> None:
    with virtual_uno(board_id=0x0034, fixture="loopback") as uno, open_board(uno.port) as board:
        led = board.digital_output(D4, initial=True)
        board.arm_failsafe(100, {led: False})
        time.sleep(0.5)  # the script does nothing for five failsafe timeouts
        status = board.status()
        assert status.flags & p.StatusFlags.FAILSAFE_ARMED
        assert not status.flags & p.StatusFlags.FAILSAFE_TRIPPED
        assert led.read() is True
        board.disarm_failsafe()


# A script that opens a board with connect() and never calls close(), then ends or raises.
UNCLOSED_SCRIPT = """
import sys
from arduinoio_async import A0
from arduinoio_async.blocking import connect

board = connect(sys.argv[1])
print(board.analog(A0).read_volts(), flush=True)
if sys.argv[2] == "raise":
    raise RuntimeError("the script failed before close()")
"""


@pytest.mark.parametrize("ending", ["return", "raise"])
def test_a_script_that_never_closes_its_board_still_exits(ending: str) -> None:
    with virtual_uno(board_id=0x0035) as uno:
        result = subprocess.run(
            [sys.executable, "-c", UNCLOSED_SCRIPT, uno.port, ending],
            capture_output=True,
            text=True,
            timeout=60,  # the bound: it hung forever before (killed here, a TimeoutExpired)
            check=False,
        )
        assert 0.0 <= float(result.stdout) <= 5.0, result.stdout  # it did talk to the board
        if ending == "return":
            assert result.returncode == 0 and result.stderr == "", result.stderr
        else:
            assert result.returncode == 1
            lines = result.stderr.splitlines()
            assert lines[0] == "Traceback (most recent call last):", result.stderr
            assert lines[-1] == "RuntimeError: the script failed before close()", result.stderr
        with open_board(uno.port) as again:  # the port was released: the board was closed
            assert again.read_id() == 0x0035


def test_a_script_drives_a_motor_and_a_wide_servo() -> None:
    """The blocking pwm/motor/servo limits, checked on the fixture's pins."""
    with virtual_uno(board_id=0x0032) as uno, open_board(uno.port) as board:
        motor = board.motor(D5, D7, D8, frequency_hz=62500)
        motor.set_speed(-0.5)
        assert (level(uno, "D7"), level(uno, "D8")) == (0, 1)
        motor.brake()
        assert (level(uno, "D7"), level(uno, "D8")) == (1, 1)
        servo = board.servo(D9, min_us=500, max_us=2500)
        servo.set_pulse(2500)
        assert servo.handle.pulse_us == 2500
        fan = board.pwm(D3, 0.25)
        fan.set_duty(0.75)
        assert fan.handle.duty == pytest.approx(0.75, abs=1 / 200)
        board.arm_failsafe(200, {motor: 0, fan: 0.0})
        board.disarm_failsafe()


def level(uno: VirtualUno, pin: str) -> int:
    """The level the fixture sees on ``pin``, asked from this plain thread."""
    return int(control_now(uno, "pin", pin=pin)["level"])
