"""The blocking handles: each method runs the async handle's method of the same name.

:class:`Runner` is the portal of one opened board, shared by its handles; the board
itself (:class:`~arduinoio_async.blocking.BlockingBoard`) and the functions that open it
are in the package's ``__init__``, with the theory of operation.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterator
from typing import Any, TypeVar

from anyio.from_thread import BlockingPortal

from ..board.handles import (
    AnalogInput,
    Counter,
    DigitalInput,
    DigitalOutput,
    Gpio,
    I2CBus,
    PinHandle,
    PinState,
    PulseOutput,
)
from ..board.motors import DutyPwm, Motor
from ..board.streaming import Sample, SampleStream
from ..errors import BoardDisconnectedError
from ..protocol.pins import DigitalPin

T = TypeVar("T")

__all__ = [
    "BlockingAnalogInput",
    "BlockingCounter",
    "BlockingDigitalInput",
    "BlockingDigitalOutput",
    "BlockingDutyPwm",
    "BlockingGpio",
    "BlockingI2CBus",
    "BlockingMotor",
    "BlockingPulseOutput",
    "BlockingSamples",
    "Runner",
]


class Runner:
    """The portal of one opened board, shared by its handles; refuses calls once closed."""

    def __init__(self, portal: BlockingPortal) -> None:
        self.portal = portal
        self.closed = False

    def call(self, func: Callable[..., Awaitable[T]], *args: Any) -> T:
        if self.closed:
            raise BoardDisconnectedError("the board was closed (BlockingBoard.close)")
        return self.portal.call(func, *args)


class _Blocking:
    """A handle of the async API and the runner of its board."""

    def __init__(self, runner: Runner, handle: Any) -> None:
        self._runner = runner
        self.handle = handle

    def __repr__(self) -> str:
        return f"<blocking {self.handle!r}>"


class _BlockingPin(_Blocking):
    """A pin handle's blocking twin: the pin and its release, shared by every kind."""

    handle: PinHandle

    @property
    def pin(self) -> DigitalPin:
        """The pin this handle holds."""
        return self.handle.pin

    def release(self) -> None:
        """End the pin's role on the board so another role may use it (the handle is stale
        afterwards)."""
        self._runner.call(self.handle.release)


class BlockingGpio(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.handles.Gpio`: an output on its first write, an
    input on its first read."""

    handle: Gpio

    def write(self, value: bool) -> None:
        """Drive the pin high (True) or low (False), making it an output first if needed."""
        self._runner.call(self.handle.write, value)

    def read(self) -> PinState:
        """The level now and the edges latched since the previous read (an unused pin
        becomes an input; an output reads the level it drives)."""
        return self._runner.call(self.handle.read)

    def configure_input(self, *, pull_up: bool = False) -> None:
        """Make the pin an input now, with the internal pull-up if asked."""
        self._runner.call(lambda: self.handle.configure_input(pull_up=pull_up))


class BlockingDigitalOutput(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.handles.DigitalOutput`: a level the board replays."""

    handle: DigitalOutput

    def write(self, value: bool) -> None:
        """Drive the pin high (True) or low (False); the level is replayed after a reset."""
        self._runner.call(self.handle.write, value)

    def read(self) -> bool:
        """The level the pin drives now."""
        return self._runner.call(self.handle.read)


class BlockingDigitalInput(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.handles.DigitalInput`: edges latched between
    reads."""

    handle: DigitalInput

    def read(self) -> PinState:
        """The level now and the edges latched since the previous read."""
        return self._runner.call(self.handle.read)


class BlockingAnalogInput(_Blocking):
    """Blocking :class:`~arduinoio_async.board.handles.AnalogInput` (A0-A5, 10 bits against
    AVCC)."""

    handle: AnalogInput

    def read(self) -> int:
        """One conversion, raw: 0-1023."""
        return self._runner.call(self.handle.read)

    def read_volts(self) -> float:
        """One conversion in volts (0-5 V against the Uno's AVCC)."""
        return self._runner.call(self.handle.read_volts)


class BlockingPulseOutput(_BlockingPin):
    """A servo (D9/D10) or software-PWM (D2-D7) output."""

    handle: PulseOutput

    def set_pulse(self, pulse_us: int) -> None:
        """Send pulses ``pulse_us`` microseconds wide (1000-2000; 0 stops them); raises
        ValueRangeError outside that range."""
        self._runner.call(self.handle.set_pulse, pulse_us)

    def set_angle(
        self, degrees: float, *, min_us: int | None = None, max_us: int | None = None
    ) -> None:
        """Set a servo to ``degrees`` (0-180), mapped linearly onto ``min_us``-``max_us``
        (by default the servo's limits)."""
        self._runner.call(lambda: self.handle.set_angle(degrees, min_us=min_us, max_us=max_us))

    def stop(self) -> None:
        """Stop the pulses (the line stays low); the pin keeps its role."""
        self._runner.call(self.handle.stop)


class BlockingDutyPwm(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.motors.DutyPwm` (D3, D5, D6, D9, D10)."""

    handle: DutyPwm

    def set_duty(self, duty: float) -> None:
        """High for ``duty`` (0.0-1.0) of every period, from the next period on."""
        self._runner.call(self.handle.set_duty, duty)


class BlockingMotor(_Blocking):
    """Blocking :class:`~arduinoio_async.board.motors.Motor`: signed speed, brake, coast."""

    handle: Motor

    def set_speed(self, speed: float) -> None:
        """Signed speed -1.0..1.0 (negative = reverse)."""
        self._runner.call(self.handle.set_speed, speed)

    def brake(self) -> None:
        """Short the motor's terminals: it stops fast."""
        self._runner.call(self.handle.brake)

    def coast(self) -> None:
        """Open the motor's terminals: it spins down by itself."""
        self._runner.call(self.handle.coast)


class BlockingCounter(_BlockingPin):
    """Blocking :class:`~arduinoio_async.board.handles.Counter` (D2 or D3)."""

    handle: Counter

    def read(self) -> int:
        """The edges counted since set-up or the last :meth:`reset`."""
        return self._runner.call(self.handle.read)

    def reset(self) -> int:
        """Clear the counter; returns the count it had (read and clear are atomic)."""
        return self._runner.call(self.handle.reset)


class BlockingI2CBus(_Blocking):
    """Blocking :class:`~arduinoio_async.board.handles.I2CBus`: register reads and writes on
    A4/A5."""

    handle: I2CBus

    def read(self, address: int, register: int, length: int) -> bytes:
        """Read ``length`` (1-32) bytes from ``register`` of the device at 7-bit
        ``address``; raises I2CError on a NACK or a bus timeout."""
        return self._runner.call(self.handle.read, address, register, length)

    def write(self, address: int, register: int, data: bytes) -> None:
        """Write up to 32 bytes to ``register`` of the device at 7-bit ``address``;
        raises I2CError on a NACK or a bus timeout."""
        self._runner.call(self.handle.write, address, register, data)

    def scan(self) -> list[int]:
        """The addresses 0x08-0x77 a device acknowledges (``arduinoio i2c scan``)."""
        return self._runner.call(self.handle.scan)


class BlockingSamples(_Blocking):
    """The samples of a running stream as a plain iterator (``for s in samples``)."""

    handle: SampleStream

    def __iter__(self) -> Iterator[Sample]:
        return self

    def __next__(self) -> Sample:
        try:
            return self._runner.call(self.handle.__anext__)
        except StopAsyncIteration:
            raise StopIteration from None

    @property
    def gaps(self) -> int:
        """Samples lost on the line or skipped by the board, by their sequence numbers."""
        return self.handle.gaps

    @property
    def dropped(self) -> int:
        """Samples dropped (the oldest) because this code did not read them in time."""
        return self.handle.dropped
