"""Blocking use, for scripts and notebooks: the async API run behind an anyio blocking portal.

Every call here is the async API's call, run to completion on an event loop that lives in
a worker thread (anyio's :func:`~anyio.from_thread.start_blocking_portal`).  No logic is
written twice: each method hands its arguments to the async method of the same name, and
the errors are the same classes.  The board's link, its keepalive heartbeat and its
failsafe feeding run in that loop between your calls, so a script that sleeps with
``time.sleep`` still feeds an armed failsafe.

Scripts use a ``with`` block::

    from arduinoio_async import D2
    from arduinoio_async.blocking import open_board

    with open_board("/dev/ttyACM0") as board:
        board.gpio(D2).write(True)

Notebooks, where a board must stay open across cells, use the explicit pair::

    board = connect("/dev/ttyACM0")      # cell 1
    board.analog(A0).read_volts()        # any later cell
    board.close()                        # when done

A script ends when its main thread ends, whether or not it called ``close()`` (also when
it raised before): the portal's event loop runs in a daemon thread, and every board that
is still open when the interpreter exits is closed by an :mod:`atexit` hook, which runs
after an uncaught exception's traceback is printed and while that thread still runs.
Without the hook the board's open portal would be torn down during interpreter
finalization, when its daemon thread can no longer run, and the script would hang there.
``close()`` (or ``with``) is still the way to let go of a board at a chosen moment.

Why a portal rather than ``asyncio.run`` per call: the link is a long-lived task (its
reader, its heartbeat), so the loop must outlive each call; and Jupyter already runs an
event loop in the main thread, which a loop of our own in a worker thread never touches.
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import weakref
from collections.abc import Iterator, Mapping, Sequence
from contextlib import AbstractContextManager, contextmanager
from types import TracebackType
from typing import Any

from anyio.from_thread import start_blocking_portal

from .. import protocol as p
from ..board import Board
from ..board.encoders import ModeName
from ..board.spi import BitOrderName
from ..board.streaming import SampleStream
from ..errors import BoardDisconnectedError
from ..opener import open_board as open_any_board
from ..protocol.boards import BoardModel
from ..protocol.pins import (
    AnalogPin,
    CounterPin,
    DigitalPin,
    DutyPwmPin,
    ServoPin,
    SoftPwmPin,
    SpiCsPin,
)
from ._encoders import BlockingEncoder
from ._handles import (
    BlockingAnalogInput,
    BlockingCounter,
    BlockingDigitalInput,
    BlockingDigitalOutput,
    BlockingDutyPwm,
    BlockingGpio,
    BlockingI2CBus,
    BlockingMotor,
    BlockingPulseOutput,
    BlockingSamples,
    Runner,
    _Blocking,
)
from ._imu import BlockingMPU6050
from ._pulse_in import BlockingPulseInput
from ._sonars import BlockingSonar
from ._spi import BlockingSpiBus
from ._stepper import BlockingStepper

_log = logging.getLogger(__name__)

__all__ = [
    "BlockingAnalogInput",
    "BlockingBoard",
    "BlockingCounter",
    "BlockingDigitalInput",
    "BlockingDigitalOutput",
    "BlockingDutyPwm",
    "BlockingGpio",
    "BlockingI2CBus",
    "BlockingMPU6050",
    "BlockingMotor",
    "BlockingPulseOutput",
    "BlockingSamples",
    "BlockingStepper",
    "connect",
    "open_board",
]


class BlockingBoard(_Blocking):
    """A :class:`~arduinoio_async.board.Board` whose methods block until they are done."""

    handle: Board

    def __init__(self, runner: Runner, board: Board, closer: contextlib.ExitStack) -> None:
        super().__init__(runner, board)
        self._closer = closer

    @property
    def board_id(self) -> int:
        """The board's ID, read when the link opened."""
        return self.handle.board_id

    @property
    def model(self) -> BoardModel:
        """What the board said it is and which pins can do what (read when it opened)."""
        return self.handle.model

    # ---- handles ------------------------------------------------------------------------

    def gpio(self, pin: DigitalPin) -> BlockingGpio:
        """A digital pin that sets itself up on first use (output on write, input on
        read); no request is sent yet."""
        return BlockingGpio(self._runner, self.handle.gpio(pin))

    def digital_output(self, pin: DigitalPin, *, initial: bool = False) -> BlockingDigitalOutput:
        """Make ``pin`` an output starting at ``initial``; raises PinCapabilityError or
        PinRoleError as :meth:`Board.digital_output
        <arduinoio_async.board.Board.digital_output>` does."""
        handle = self._runner.call(lambda: self.handle.digital_output(pin, initial=initial))
        return BlockingDigitalOutput(self._runner, handle)

    def digital_input(self, pin: DigitalPin, *, pull_up: bool = False) -> BlockingDigitalInput:
        """Make ``pin`` an input, with the internal pull-up if asked."""
        handle = self._runner.call(lambda: self.handle.digital_input(pin, pull_up=pull_up))
        return BlockingDigitalInput(self._runner, handle)

    def analog(self, pin: AnalogPin) -> BlockingAnalogInput:
        """An analog input A0-A5 (no set-up needed; A4/A5 are busy while I2C is on)."""
        return BlockingAnalogInput(self._runner, self.handle.analog(pin))

    def read_analog_all(self) -> tuple[int, ...]:
        """All six analog inputs (0-1023 each), A0 first, in one request."""
        return self._runner.call(self.handle.read_analog_all)

    def servo(
        self, pin: ServoPin, *, pulse_us: int = 0, min_us: int = 1000, max_us: int = 2000
    ) -> BlockingPulseOutput:
        """Hardware servo PWM on D9/D10 (1 us resolution); ``pulse_us`` 0 = no pulses yet;
        limits ``min_us``-``max_us`` (widen up to 500-2500 us for servos that travel so)."""
        limits = {"pulse_us": pulse_us, "min_us": min_us, "max_us": max_us}
        handle = self._runner.call(lambda: self.handle.servo(pin, **limits))
        return BlockingPulseOutput(self._runner, handle)

    def soft_pwm(
        self, pin: SoftPwmPin, *, pulse_us: int = 0, min_us: int = 1000, max_us: int = 2000
    ) -> BlockingPulseOutput:
        """Software servo PWM on D2-D7 (1 us resolution); limits as for :meth:`servo`."""
        limits = {"pulse_us": pulse_us, "min_us": min_us, "max_us": max_us}
        handle = self._runner.call(lambda: self.handle.soft_pwm(pin, **limits))
        return BlockingPulseOutput(self._runner, handle)

    def pwm(
        self, pin: DutyPwmPin, duty: float = 0.0, *, frequency_hz: int | None = None
    ) -> BlockingDutyPwm:
        """Duty-cycle PWM (``analogWrite``) on D3, D5, D6, D9 or D10 (see ``Board.pwm``)."""
        handle = self._runner.call(lambda: self.handle.pwm(pin, duty, frequency_hz=frequency_hz))
        return BlockingDutyPwm(self._runner, handle)

    def motor(
        self,
        pwm: DutyPwmPin,
        direction: DigitalPin,
        direction2: DigitalPin | None = None,
        *,
        frequency_hz: int | None = None,
    ) -> BlockingMotor:
        """A motor behind an EN/PWM + IN1 [+ IN2] driver (see ``Board.motor``)."""
        handle = self._runner.call(
            lambda: self.handle.motor(pwm, direction, direction2, frequency_hz=frequency_hz)
        )
        return BlockingMotor(self._runner, handle)

    def stepper(
        self, *, step: DigitalPin, dir: DigitalPin, max_speed: int = 1000, acceleration: int = 1000
    ) -> BlockingStepper:
        """A step/dir stepper (see ``Board.stepper``)."""
        handle = self._runner.call(
            lambda: self.handle.stepper(
                step=step, dir=dir, max_speed=max_speed, acceleration=acceleration
            )
        )
        return BlockingStepper(self._runner, handle)

    def motor_2pwm(
        self, in1: DutyPwmPin, in2: DutyPwmPin, *, frequency_hz: int | None = None
    ) -> BlockingMotor:
        """A motor behind a two-PWM driver such as the DRV8833 (see ``Board.motor_2pwm``)."""
        handle = self._runner.call(
            lambda: self.handle.motor_2pwm(in1, in2, frequency_hz=frequency_hz)
        )
        return BlockingMotor(self._runner, handle)

    def counter(self, pin: CounterPin, *, edge: p.Edge = p.Edge.RISING) -> BlockingCounter:
        """An event counter on D2 or D3 counting ``edge`` edges, from zero."""
        handle = self._runner.call(lambda: self.handle.counter(pin, edge=edge))
        return BlockingCounter(self._runner, handle)

    def encoder(
        self, a: DigitalPin, b: DigitalPin, *, mode: ModeName | int = "x4", slot: int | None = None
    ) -> BlockingEncoder:
        """A quadrature encoder on any two digital pins (see ``Board.encoder``)."""
        handle = self._runner.call(lambda: self.handle.encoder(a, b, mode=mode, slot=slot))
        return BlockingEncoder(self._runner, handle)

    def sonar(
        self, trigger: DigitalPin, echo: DigitalPin, *, slot: int | None = None
    ) -> BlockingSonar:
        """An HC-SR04 style sonar, trigger and echo on any two pins (see ``Board.sonar``)."""
        handle = self._runner.call(lambda: self.handle.sonar(trigger, echo, slot=slot))
        return BlockingSonar(self._runner, handle)

    def sonar_timing(
        self,
        *,
        period_ms: int = 60,
        speed_m_s: float | None = None,
        temperature_c: float | None = None,
    ) -> None:
        """How often the board fires a sonar, and the speed of sound (``Board.sonar_timing``)."""
        self._runner.call(
            lambda: self.handle.sonar_timing(
                period_ms=period_ms, speed_m_s=speed_m_s, temperature_c=temperature_c
            )
        )

    def pulse_input(
        self, pin: DigitalPin, *, timeout_ms: int = 100, slot: int | None = None
    ) -> BlockingPulseInput:
        """An RC receiver channel's pulse widths on any digital pin (``Board.pulse_input``)."""
        handle = self._runner.call(
            lambda: self.handle.pulse_input(pin, timeout_ms=timeout_ms, slot=slot)
        )
        return BlockingPulseInput(self._runner, handle)

    def spi(
        self,
        cs: SpiCsPin,
        *,
        mode: int = 0,
        clock_hz: int = 1_000_000,
        bit_order: BitOrderName = "msb",
    ) -> BlockingSpiBus:
        """The SPI bridge on D11-D13 with chip select ``cs`` (see ``Board.spi``)."""
        handle = self._runner.call(
            lambda: self.handle.spi(cs, mode=mode, clock_hz=clock_hz, bit_order=bit_order)
        )
        return BlockingSpiBus(self._runner, handle)

    def i2c(self, speed: p.I2CSpeed = p.I2CSpeed.KHZ_100) -> BlockingI2CBus:
        """Turn on the I2C bridge on A4/A5 at ``speed`` (100 or 400 kHz)."""
        return BlockingI2CBus(self._runner, self._runner.call(self.handle.i2c, speed))

    def release(self, pin: DigitalPin) -> None:
        """End whatever role ``pin`` has, so another role may use it."""
        self._runner.call(self.handle.release, pin)

    # ---- board ----------------------------------------------------------------------------

    def read_id(self) -> int:
        """The board ID stored in the board's EEPROM, read now."""
        return self._runner.call(self.handle.read_id)

    def write_id(self, board_id: int) -> None:
        """Store a new board ID (0x0000-0xFFFF) in EEPROM; it survives resets."""
        self._runner.call(self.handle.write_id, board_id)

    def temperature(self) -> float:
        """The chip's temperature in degrees C (datasheet-typical calibration)."""
        return self._runner.call(self.handle.temperature)

    def status(self) -> p.ReadStatusReply:
        """The board's status flags and session tag (0 after every boot)."""
        return self._runner.call(self.handle.status)

    def reset(self, *, restore: bool = False) -> None:
        """Reset the board through its watchdog and wait until it answers; with
        ``restore=True`` set the pin roles and watches up again."""
        self._runner.call(lambda: self.handle.reset(restore=restore))

    def request(self, request: p.Request[Any], *, timeout: float | None = None) -> Any:
        """A raw protocol request; returns its verified reply."""
        return self._runner.call(lambda: self.handle.request(request, timeout=timeout))

    # ---- extensions -------------------------------------------------------------------------

    def stream(
        self,
        *,
        analog: Sequence[AnalogPin] = (),
        levels: bool = False,
        edges: bool = False,
        counters: bool = False,
        period_ms: float = 10.0,
        **options: Any,
    ) -> AbstractContextManager[BlockingSamples]:
        """``with board.stream(analog=[A0], period_ms=1) as samples: for s in samples: ...``"""
        async_cm = self.handle.stream(
            analog=analog,
            levels=levels,
            edges=edges,
            counters=counters,
            period_ms=period_ms,
            **options,
        )
        if self._runner.closed:
            raise BoardDisconnectedError("the board was closed (BlockingBoard.close)")
        samples_cm = self._runner.portal.wrap_async_context_manager(async_cm)
        return _wrap_samples(self._runner, samples_cm)

    def arm_failsafe(self, timeout_ms: int, safe_states: Mapping[_Blocking, bool | float]) -> None:
        """Arm the board's link watchdog: when the host is silent for ``timeout_ms`` the
        outputs in ``safe_states`` (blocking handles) take their safe level or pulse width
        (us).  The portal's loop feeds it between your calls."""
        states = {blocking.handle: state for blocking, state in safe_states.items()}
        self._runner.call(self.handle.arm_failsafe, timeout_ms, states)

    def disarm_failsafe(self) -> None:
        """Stop the board's link watchdog (before a planned pause of the program)."""
        self._runner.call(self.handle.disarm_failsafe)

    def rearm_failsafe(self, *, restore: bool = True) -> None:
        """After a trip: arm again and (by default) put every output back as it was."""
        self._runner.call(lambda: self.handle.rearm_failsafe(restore=restore))

    # ---- closing ------------------------------------------------------------------------------

    def close(self) -> None:
        """Close the board and stop its event loop (for :func:`connect`; idempotent)."""
        _open_boards.discard(self)
        if not self._runner.closed:
            self._runner.closed = True
            self._closer.close()

    def __enter__(self) -> BlockingBoard:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


@contextmanager
def _wrap_samples(
    runner: Runner, samples_cm: AbstractContextManager[SampleStream]
) -> Iterator[BlockingSamples]:
    with samples_cm as samples:
        yield BlockingSamples(runner, samples)


@contextmanager
def open_board(port: str, *, backend: str = "asyncio", **options: Any) -> Iterator[BlockingBoard]:
    """Open ``port`` as :func:`arduinoio_async.open_board` does (same keyword options) for
    blocking use."""
    board = connect(port, backend=backend, **options)
    try:
        yield board
    finally:
        board.close()


def connect(port: str, *, backend: str = "asyncio", **options: Any) -> BlockingBoard:
    """Open ``port`` and keep it open until :meth:`BlockingBoard.close` (notebook cells).

    The board's link runs on an event loop in a worker thread; ``backend`` picks anyio's
    backend for it ("asyncio" or "trio").
    """
    stack = contextlib.ExitStack()
    try:
        portal = stack.enter_context(start_blocking_portal(backend))
        board = stack.enter_context(
            portal.wrap_async_context_manager(open_any_board(port, **options))
        )
    except BaseException:
        stack.close()
        raise
    blocking = BlockingBoard(Runner(portal), board, stack)
    _open_boards.add(blocking)
    return blocking


#: Boards opened by :func:`connect` and not closed yet; weak, so a dropped board is not kept.
_open_boards: weakref.WeakSet[BlockingBoard] = weakref.WeakSet()


@atexit.register
def _close_open_boards() -> None:
    """Close what a script left open, so that it exits (see the module docstring)."""
    for board in list(_open_boards):
        try:
            board.close()
        except Exception as exc:  # the script is ending: say why, do not print a traceback
            _log.warning("closing %r at exit failed: %s", board, exc)
