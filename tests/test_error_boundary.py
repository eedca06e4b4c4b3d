"""Only the library's own exceptions cross its boundary, whatever the line does.

Every public coroutine of :class:`Board` is called on a board that goes silent (every
reply lost), on a line so noisy that most replies are damaged, and on a board whose cable
was pulled.  A call may succeed or raise; what it raises must be an
:class:`~arduinoio_async.errors.ArduinoIOError` (``write_id`` once let a builtin
``TimeoutError`` escape when its reply was lost and the board stayed silent past the
read-back deadline).  A new public coroutine fails ``test_the_scan_covers_every_public
coroutine`` until it gets a call here.
"""

from __future__ import annotations

import inspect
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, replace

import anyio
import pytest

from arduinoio_async import D2, D3, D4, D5, D6, D7, D8, D9, D10, D11, D12, D13
from arduinoio_async import protocol as p
from arduinoio_async.board import Board
from arduinoio_async.board.handles import DigitalOutput, output_setup
from arduinoio_async.errors import ArduinoIOError
from arduinoio_async.testing import FakeBoard
from arduinoio_async.testing._faults import Faults

#: Short enough to keep the scan fast; every wait in these calls is bounded by them.
TIMEOUT = 0.05
DEADLINE = 0.3


@dataclass
class Scene:
    board: Board
    fake: FakeBoard
    led: DigitalOutput
    line: str


async def run_keepalive(s: Scene) -> None:
    with anyio.move_on_after(DEADLINE):  # runs until the link closes: a while is enough
        await s.board.keepalive(s.board.link)


async def start_link(s: Scene) -> None:
    async with FakeBoard(board_id=0x0044, faults=replace(s.fake.faults)) as other:
        if s.line == "unplugged":
            await other.unplug()
        link = await Board.start_link(other.host_stream, timeout=TIMEOUT, ready_timeout=DEADLINE)
        await link.aclose()


async def use_stream(s: Scene) -> None:
    async with s.board.stream(analog=[p.pins.AnalogPin.A0], period_ms=5) as samples:
        async for _ in samples:
            break


async def use_transaction(s: Scene) -> None:
    async with s.board.transaction() as tx:
        tx.add(p.ReadId())


CALLS: dict[str, Callable[[Scene], Awaitable[object]]] = {
    "adopt": lambda s: s.board.adopt(s.board.link),
    "arm_failsafe": lambda s: s.board.arm_failsafe(100, {s.led: False}),
    "choose_low_latency": lambda s: s.board.choose_low_latency(False),
    "counter": lambda s: s.board.counter(D2),
    "digital_input": lambda s: s.board.digital_input(D5),
    "encoder": lambda s: s.board.encoder(D11, D12),
    "digital_output": lambda s: s.board.digital_output(D6),
    "disarm_failsafe": lambda s: s.board.disarm_failsafe(),
    "from_link": lambda s: Board.from_link(s.board.link),
    "i2c": lambda s: s.board.i2c(),
    "keepalive": run_keepalive,
    "motor": lambda s: s.board.motor(D5, D8),
    "motor_2pwm": lambda s: s.board.motor_2pwm(D9, D10),
    "pwm": lambda s: s.board.pwm(D10, 0.5),
    "read_analog_all": lambda s: s.board.read_analog_all(),
    "read_id": lambda s: s.board.read_id(),
    "rearm_failsafe": lambda s: s.board.rearm_failsafe(),
    "release": lambda s: s.board.release(D4),
    "request": lambda s: s.board.request(p.ReadTemperature()),
    "reset": lambda s: s.board.reset(deadline=DEADLINE),
    "restore": lambda s: s.board.restore(),
    "servo": lambda s: s.board.servo(D9, pulse_us=1500),
    "set_low_latency": lambda s: s.board.set_low_latency(False),
    "set_up": lambda s: s.board.set_up(DigitalOutput(s.board, D8), output_setup(D8, True)),
    "soft_pwm": lambda s: s.board.soft_pwm(D3, pulse_us=1500),
    "start_link": start_link,
    "status": lambda s: s.board.status(),
    "spi": lambda s: s.board.spi(cs=D10),
    "stepper": lambda s: s.board.stepper(step=D6, dir=D7),
    "pulse_input": lambda s: s.board.pulse_input(D4),
    "sonar": lambda s: s.board.sonar(D11, D13),
    "sonar_timing": lambda s: s.board.sonar_timing(period_ms=50),
    "temperature": lambda s: s.board.temperature(),
    "wait_rebooted": lambda s: s.board.wait_rebooted(deadline=DEADLINE),
    "write_id": lambda s: s.board.write_id(0x0043, deadline=DEADLINE),
    # context managers that talk to the board
    "stream": use_stream,
    "transaction": use_transaction,
}

FAULTS = {
    "silent": Faults(lose_reply=1.0),
    "noisy": Faults(seed=3, drop_byte=0.1, insert_byte=0.1, flip_byte=0.1),
}


def public_coroutines() -> set[str]:
    return {
        name
        for name in dir(Board)
        if not name.startswith("_") and inspect.iscoroutinefunction(getattr(Board, name))
    }


def test_the_scan_covers_every_public_coroutine() -> None:
    assert public_coroutines() <= set(CALLS), "add a call for each new public coroutine"


@pytest.mark.parametrize("line", ["silent", "noisy", "unplugged"])
@pytest.mark.parametrize("name", sorted(CALLS))
async def test_only_library_exceptions_escape(name: str, line: str) -> None:
    async with (
        FakeBoard(board_id=0x0042) as fake,
        Board.connect(fake.host_stream, timeout=TIMEOUT, ready_timeout=2) as board,
    ):
        scene = Scene(board, fake, await board.digital_output(D7, initial=True), line)
        await board.digital_output(D4)
        if line == "unplugged":
            await fake.unplug()
        else:
            fake.faults = replace(FAULTS[line])
        with anyio.fail_after(10):  # a hang is a failure too
            try:
                await CALLS[name](scene)
            except ArduinoIOError:
                pass
            except BaseException as exc:
                pytest.fail(f"{name} on a {line} line raised {type(exc).__name__}: {exc!r}")
