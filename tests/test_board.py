"""Board and handles against the in-memory fake board: behaviour and misuse."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import anyio
import pytest

from arduinoio_async import (
    A0,
    A4,
    D2,
    D3,
    D4,
    D5,
    D9,
    D10,
    PinCapabilityError,
    PinRoleError,
    StaleHandleError,
    ValueRangeError,
)
from arduinoio_async import manager as manager_module
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.handles import PinState
from arduinoio_async.errors import BoardDisconnectedError
from arduinoio_async.manager import BoardManager
from arduinoio_async.testing import FakeBoard
from arduinoio_async.transport import memory_link

from .fake_boards import connected


async def test_connect_reads_id_capabilities_and_tags_the_session() -> None:
    async with connected() as (board, fake):
        assert board.board_id == 0x0042
        assert board.capabilities.protocol_version == p.PROTOCOL_VERSION
        assert fake.session == board.session != 0


async def test_the_design_cards_line() -> None:
    async with connected() as (board, fake):
        await board.gpio(D2).write(True)
        assert fake.levels[2] is True
        assert fake.role(2) == "output"
        await board.gpio(D2).write(False)
        assert fake.levels[2] is False


async def test_gpio_read_configures_an_input_and_reports_edges() -> None:
    async with connected() as (board, fake):
        pin = board.gpio(D3)
        assert await pin.read() == PinState(False, False, False)
        fake.drive(3, True)
        fake.drive(3, False)
        fake.drive(3, True)
        state = await pin.read()
        assert state == PinState(True, True, True)
        assert state
        assert await pin.read() == PinState(True, False, False)


async def test_explicit_handles_do_what_they_say() -> None:
    async with connected() as (board, fake):
        out = await board.digital_output(D4, initial=True)
        assert fake.levels[4] is True
        await out.write(False)
        assert await out.read() is False
        inp = await board.digital_input(D5, pull_up=True)
        assert (await inp.read()).level is True  # nothing attached: the pull-up wins
        fake.drive(5, False)
        fake.drive(5, True)
        assert (await inp.read()).rose
        fake.analog[0] = 512
        assert await board.analog(A0).read() == 512
        assert await board.analog(A0).read_volts() == pytest.approx(2.5)
        servo = await board.servo(D9, pulse_us=1500)
        assert fake.pulses[9] == 1500
        await servo.set_angle(180)
        assert fake.pulses[9] == 2000
        soft = await board.soft_pwm(D2, pulse_us=1200)
        await soft.set_pulse(1800)
        assert fake.pulses[2] == 1800
        counter = await board.counter(D3)  # counts rising edges only, as the firmware does
        fake.drive(3, True)
        fake.drive(3, False)
        fake.drive(3, True)
        assert await counter.read() == 2
        assert await counter.reset() == 2
        assert await counter.read() == 0
        bus = await board.i2c()
        await bus.write(0x50, 0x10, b"\x01\x02\x03")
        assert await bus.read(0x50, 0x10, 3) == b"\x01\x02\x03"
        assert await board.read_analog_all() == tuple(fake.analog)


async def test_a_pin_in_one_role_refuses_another_until_released() -> None:
    async with connected() as (board, _fake):
        await board.digital_output(D9)
        with pytest.raises(PinRoleError, match="D9 is in use as digital output"):
            await board.servo(D9)
        with pytest.raises(PinRoleError):
            await board.gpio(D9).write(True)
        await board.release(D9)
        servo = await board.servo(D9, pulse_us=1000)
        assert servo.pulse_us == 1000


async def test_analog_a4_a5_are_busy_while_i2c_is_on() -> None:
    async with connected() as (board, _fake):
        await board.i2c()
        with pytest.raises(PinRoleError):
            board.analog(A4)


@pytest.mark.parametrize(
    "misuse",
    [
        lambda b: b.servo(D2),
        lambda b: b.soft_pwm(D9),
        lambda b: b.counter(D4),
        lambda b: b.servo(D9, pulse_us=2500),
        lambda b: b.servo(D10, pulse_us=999),
        lambda b: b.soft_pwm(D2, pulse_us=2001),
        lambda b: b.write_id(0x10000),
    ],
)
async def test_misuse_raises_before_anything_is_sent(misuse: object) -> None:
    async with connected() as (board, fake):
        seen = fake.requests_seen
        with pytest.raises((PinCapabilityError, ValueRangeError)):
            await misuse(board)  # type: ignore[operator]
        assert fake.requests_seen == seen


async def test_value_errors_on_handles_are_raised_locally() -> None:
    async with connected() as (board, fake):
        servo = await board.servo(D10)
        bus = await board.i2c()
        seen = fake.requests_seen
        for call in (
            lambda: servo.set_pulse(2001),
            lambda: servo.set_angle(181),
            lambda: bus.read(0x50, 0, 33),
            lambda: bus.read(0x80, 0, 1),
            lambda: bus.write(0x50, 256, b"x"),
            lambda: bus.write(0x50, 0, bytes(33)),
        ):
            with pytest.raises(ValueRangeError):
                await call()
        assert fake.requests_seen == seen


async def test_restore_replays_the_configuration() -> None:
    async with connected() as (board, fake):
        await board.gpio(D2).write(True)
        servo = await board.servo(D9, pulse_us=1500)
        await servo.set_pulse(1700)
        await board.counter(D3)
        await board.i2c(p.I2CSpeed.KHZ_400)
        await board.request(p.Reset())
        assert fake.role(2) == "free" and 9 not in fake.pulses
        await board.restore()
        assert fake.role(2) == "output" and fake.levels[2] is True
        assert fake.pulses[9] == 1700
        assert fake.role(3) == "counter"


async def test_write_id_then_read_id() -> None:
    async with connected() as (board, _fake):
        await board.write_id(0x0007)
        assert await board.read_id() == 0x0007


def test_mypy_rejects_a_servo_on_a_pin_table_iii_forbids(tmp_path: Path) -> None:
    snippet = tmp_path / "misuse.py"
    snippet.write_text(
        textwrap.dedent(
            """
            from arduinoio_async import D2, D9
            from arduinoio_async.board import Board

            async def main(board: Board) -> None:
                await board.servo(D9)
                await board.servo(D2)
                await board.counter(D9)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(snippet)],
        capture_output=True,
        text=True,
        check=False,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 2, result.stdout
    assert "misuse.py:7" in errors[0] and "misuse.py:8" in errors[1]


def test_mypy_checks_a_mega_against_the_megas_pins_and_an_uno_against_the_unos(
    tmp_path: Path,
) -> None:
    """Mega2560Board takes the Mega's pin types (protocol/pins_mega.py), Board the Uno's."""
    snippet = tmp_path / "mega.py"
    snippet.write_text(
        textwrap.dedent(
            """
            from arduinoio_async.board import Board, Mega2560Board
            from arduinoio_async.protocol.pins import D9, D18, D24, D44

            async def main(uno: Board, mega: Mega2560Board) -> None:
                await mega.servo(D44)
                await mega.counter(D18)
                await mega.soft_pwm(D24)
                await mega.servo(D9)
                await uno.servo(D44)
                await uno.counter(D18)
                async with Mega2560Board.open("/dev/ttyACM0") as opened:
                    await opened.pwm(D44)
                    await opened.pwm(D9)
            """
        )
    )
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(snippet)],
        capture_output=True,
        text=True,
        check=False,
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert [e.split(":")[1] for e in errors] == ["9", "10", "11", "14"], result.stdout


# ---- defects once found in the link core, kept fixed -------------------------------------


def test_a_reboot_wait_on_a_closing_link_ends_instead_of_freezing() -> None:
    """``except LinkError: continue`` on a closed link was a busy loop no timeout could stop
    (it never reached a checkpoint); run in a thread so a freeze fails the test."""
    outcome: list[str] = []

    async def scenario() -> None:
        async with connected() as (board, fake):
            fake.faults.lose_reply = 1.0

            waiting = anyio.Event()  # the first status poll went unanswered
            board.link.on_state_change(lambda state: waiting.set())

            async def unplug_when_waiting() -> None:
                await waiting.wait()
                await board.link.aclose()

            async with anyio.create_task_group() as tg:
                tg.start_soon(unplug_when_waiting)
                with pytest.raises(BoardDisconnectedError):
                    await board.wait_rebooted(deadline=3)
        outcome.append("raised")

    thread = threading.Thread(target=anyio.run, args=(scenario,), daemon=True)
    thread.start()
    thread.join(20)
    assert not thread.is_alive(), "wait_rebooted() froze the event loop"
    assert outcome == ["raised"]


async def test_a_failing_failsafe_listener_is_logged_and_isolated(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async with connected() as (board, fake):
        seen: list[Board] = []

        def buggy(_board: Board) -> None:
            raise RuntimeError("listener bug")

        board.on_failsafe(buggy)
        board.on_failsafe(seen.append)
        await fake.push(p.FailsafeTripped())
        assert await board.read_id() == 0x0042  # the event was handled before this reply
        assert seen == [board]
        assert board.failsafe_tripped
        assert "listener bug" in caplog.text


async def test_a_stream_without_buffer_is_refused_before_anything_is_sent() -> None:
    async with connected() as (board, fake):
        seen = fake.requests_seen
        with pytest.raises(ValueRangeError):
            async with board.stream(analog=[A0], buffer=0):
                pass
        assert fake.requests_seen == seen
        assert await board.read_id() == 0x0042


async def test_write_id_whose_reply_is_lost_keeps_the_link() -> None:
    async with connected() as (board, fake):
        fake.faults.lose_reply = 1.0
        async with anyio.create_task_group() as tg:
            tg.start_soon(board.write_id, 0x0043)
            while fake.board_id != 0x0043:  # the board took the new ID; its reply is lost
                await anyio.wait_all_tasks_blocked()
            fake.faults.lose_reply = 0.0
        assert board.board_id == 0x0043
        assert board.link.expected_id == 0x0043
        assert await board.read_id() == 0x0043
        assert board.connected


async def test_a_port_lost_during_the_boot_wait_is_a_disconnect() -> None:
    host, peer = memory_link()
    await peer.aclose()
    with pytest.raises(BoardDisconnectedError):
        async with Board.connect(host, ready_timeout=1):
            pass


def test_a_manager_whose_first_scan_fails_exits_its_task_group_on_trio(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def broken_scan(*args: object, **kwargs: object) -> list[str]:
        raise OSError("port listing failed")

    monkeypatch.setattr(manager_module, "candidate_ports", broken_scan)

    async def scenario() -> None:
        with pytest.raises(OSError, match="port listing failed"):
            async with BoardManager(usb=False, env=False, rescan_interval=None):
                pass

    anyio.run(scenario, backend="trio")


async def test_a_released_handle_refuses_to_drive_its_pin() -> None:
    async with connected() as (board, fake):
        old = await board.digital_output(D4)
        await old.release()
        new = await board.digital_output(D4, initial=True)
        with pytest.raises(StaleHandleError, match=r"D4.*was released"):
            await old.write(False)
        with pytest.raises(StaleHandleError, match="was released"):
            await old.read()
        assert fake.levels[4] is True  # the new owner's level stands
        await new.write(False)
        assert fake.levels[4] is False
        servo = await board.servo(D9, pulse_us=1500)
        await board.release(D9)
        with pytest.raises(StaleHandleError, match=r"D9.*was released"):
            await servo.set_pulse(1200)
        gpio = board.gpio(D5)
        await gpio.write(True)
        await board.release(D5)
        with pytest.raises(StaleHandleError, match="was released"):
            await gpio.write(True)
        assert fake.role(5) != "output"


async def test_arm_failsafe_refuses_another_boards_handle_and_a_released_one() -> None:
    async with connected() as (board, _fake):
        async with (
            FakeBoard(board_id=0x0043) as other_fake,
            Board.connect(other_fake.host_stream, timeout=0.5, ready_timeout=2) as other,
        ):
            foreign = await other.digital_output(D4)
            await board.digital_output(D4)
            with pytest.raises(StaleHandleError, match="belongs to another board"):
                await board.arm_failsafe(200, {foreign: False})
        released = await board.digital_output(D5)
        await released.release()
        with pytest.raises(StaleHandleError, match="was released"):
            await board.arm_failsafe(200, {released: False})
        assert board.failsafe is None  # nothing was stored


async def test_a_non_integer_failsafe_timeout_is_refused_before_it_is_stored() -> None:
    async with connected() as (board, _fake):
        with pytest.raises(ValueRangeError, match="whole number of ms"):
            await board.arm_failsafe(100.5, {})  # type: ignore[arg-type]
        assert board.failsafe is None
        await board.arm_failsafe(100, {})  # a later arm works
        assert board.failsafe is not None
        assert board.failsafe.timeout_ms == 100
        await board.rearm_failsafe()


async def test_a_nan_stream_period_is_a_value_range_error() -> None:
    async with connected() as (board, _fake):
        for period in (float("nan"), float("inf")):
            with pytest.raises(ValueRangeError, match="stream period"):
                async with board.stream(analog=[A0], period_ms=period):
                    pass
        with pytest.raises(ValueRangeError, match="stream buffer"):
            async with board.stream(analog=[A0], buffer=0):
                pass
