"""Typed pin handles: what robot code holds on to.

A handle knows its board and its pin, never the port: when a board is replaced by a fresh
connection (reset, replug) the manager re-attaches the same :class:`Board`, and every
handle keeps working.  Handles take their pin through :meth:`Board.set_up
<arduinoio_async.board.Board.set_up>` and record every later change of their set-up
(direction, pull-up, last pulse) in the board's public role table
(:class:`~arduinoio_async.board.PinRoles`), which the board replays after a reconnect.

Values are checked before anything is sent, with errors that say what is allowed.
"""

from __future__ import annotations

import functools
from collections.abc import AsyncGenerator, AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

from .. import protocol as p
from ..errors import I2CError, StaleHandleError, ValueRangeError
from ..protocol.pins import AnalogPin, DigitalPin, Function
from .changes import (
    DEFAULT_CHANGE_BUFFER,
    AnalogChanges,
    AnalogMove,
    Change,
    ChangeStream,
    CountReports,
    watch_analog,
    watch_changes,
    watch_counter,
)

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = [
    "AnalogInput",
    "Counter",
    "DigitalInput",
    "DigitalOutput",
    "Gpio",
    "I2CBus",
    "PinHandle",
    "PinState",
    "PulseOutput",
    "Servo",
    "SoftPwm",
    "input_setup",
    "output_setup",
]


class PinState(NamedTuple):
    """A digital read: the level now and the edges seen since the previous read.

    Truthy when the level is high, so ``if await pin.read():`` reads naturally.
    """

    level: bool
    rose: bool
    fell: bool

    def __bool__(self) -> bool:
        return self.level

    @classmethod
    def from_reply(cls, reply: p.GpioReadReply) -> PinState:
        """The state a ``GpioRead`` reply carries (for code that sends raw requests)."""
        return cls(reply.level, reply.rose, reply.fell)


class PinHandle:
    """What every pin handle shares: its board, its pin, and the role it holds there.

    The board's :class:`~arduinoio_async.board.PinRoles` records which handle holds each
    pin; a handle whose role ended is marked :attr:`released` and refuses to touch the pin.
    """

    ROLE: str = "pin"

    def __init__(self, board: BoardCore, pin: DigitalPin) -> None:
        self.board = board
        self.pin = pin
        #: Set when the pin's role ended (``release()`` or ``board.release(pin)``): the pin
        #: may belong to another handle now, so this one refuses to touch it.
        self.released = False

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.pin.name} on {self.board}>"

    def check_usable(self) -> None:
        """Raise :class:`StaleHandleError` if this handle's role on the pin was released."""
        if self.released:
            raise StaleHandleError(
                repr(self),
                f"was released ({self.pin.name}'s role ended); ask the board for a new handle",
            )

    async def release(self) -> None:
        """End the pin's role on the board so another role may use it."""
        self.check_usable()
        await self.board.release(self.pin)


class DigitalOutput(PinHandle):
    """A digital output on D2-D13."""

    ROLE = "digital output"

    async def write(self, value: bool) -> None:
        """Drive the pin high (True) or low (False); the level is recorded, so a reset or
        a reconnect restores it.  Raises StaleHandleError after the role was released."""
        self.check_usable()
        reply = await self.board.request(p.GpioWrite(self.pin, bool(value)))
        self.board.roles.amend(self, output_setup(self.pin, reply.value))

    async def read(self) -> bool:
        """The level the pin drives now."""
        self.check_usable()
        reply = await self.board.request(p.GpioRead(self.pin))
        return reply.level


class _Watchable(PinHandle):
    """Input change events (extension, :mod:`arduinoio_async.board.changes`)."""

    async def _as_input(self) -> None:
        """Make the pin an input if it is not one (Gpio); DigitalInput already is."""

    def watch(
        self,
        *,
        buffer: int = DEFAULT_CHANGE_BUFFER,
        callback: Callable[[Change], None] | None = None,
    ) -> AbstractAsyncContextManager[ChangeStream]:
        """``async with pin.watch() as changes: async for change in changes: ...``: the
        board reports each change of this input until the block ends."""

        @asynccontextmanager
        async def scope() -> AsyncIterator[ChangeStream]:
            await self._as_input()
            async with watch_changes(self.board, self.pin, buffer, callback) as stream:
                yield stream

        return scope()

    async def changes(self, *, buffer: int = DEFAULT_CHANGE_BUFFER) -> AsyncGenerator[Change, None]:
        """``async for change in board.gpio(D3).changes():`` each change as it happens.

        Leaving the loop early unsubscribes when the generator is closed (at once with
        ``contextlib.aclosing``, else when the event loop finalizes it); :meth:`watch`
        ends the subscription exactly at the end of its block.
        """
        async with self.watch(buffer=buffer) as stream:
            async for change in stream:
                yield change

    def on_change(
        self, callback: Callable[[Change], None]
    ) -> AbstractAsyncContextManager[ChangeStream]:
        """``async with pin.on_change(cb):`` calls ``cb(change)`` for each change while the
        block runs (on the link's reader: keep it short; exceptions are logged)."""
        return self.watch(callback=callback)


class DigitalInput(_Watchable):
    """A digital input on D2-D13, optionally with pull-up."""

    ROLE = "digital input"

    async def read(self) -> PinState:
        """Level now, and the rising/falling edges latched since the previous read."""
        self.check_usable()
        return PinState.from_reply(await self.board.request(p.GpioRead(self.pin)))


@functools.cache
def output_setup(pin: DigitalPin, level: bool) -> p.GpioConfig:
    """The request that makes ``pin`` an output driving ``level`` (its role's replay record).

    Cached: every write records its level this way, and building and validating a fresh
    request each time was a tenth of a pipelined write's CPU (the requests are frozen).
    """
    flags = p.GpioFlags.OUTPUT | (p.GpioFlags.INITIAL_HIGH if level else p.GpioFlags.INPUT)
    return p.GpioConfig(pin, flags)


@functools.cache
def input_setup(pin: DigitalPin, pull_up: bool) -> p.GpioConfig:
    """The request that makes ``pin`` an input, with or without its pull-up."""
    return p.GpioConfig(pin, p.GpioFlags.PULL_UP if pull_up else p.GpioFlags.INPUT)


class Gpio(_Watchable):
    """A digital pin that becomes an output on its first write, an input on its first read.

    For robot code that just wants ``await board.gpio(D2).write(True)``.  Reading a pin
    that is an output returns the level it drives.
    """

    ROLE = "GPIO"

    def __init__(self, board: BoardCore, pin: DigitalPin) -> None:
        super().__init__(board, pin)
        self.direction: str | None = None

    async def write(self, value: bool) -> None:
        """Drive the pin high (True) or low (False), making it an output first if it is not
        one (it starts at ``value``, no glitch).  Raises StaleHandleError after a release."""
        self.check_usable()
        if self.direction != "output":
            await self.board.set_up(self, output_setup(self.pin, bool(value)))
            self.direction = "output"
            return
        reply = await self.board.request(p.GpioWrite(self.pin, bool(value)))
        self.board.roles.amend(self, output_setup(self.pin, reply.value))

    async def read(self) -> PinState:
        """The level now and the edges latched since the previous read; the first read of
        an unused pin makes it an input (no pull-up), an output reads the level it drives."""
        self.check_usable()
        if self.direction is None:
            await self.board.set_up(self, input_setup(self.pin, False))
            self.direction = "input"
        return PinState.from_reply(await self.board.request(p.GpioRead(self.pin)))

    async def configure_input(self, *, pull_up: bool = False) -> None:
        """Make the pin an input now, with the internal pull-up if asked (a button to
        ground needs it; :meth:`read` alone sets up an input without one)."""
        self.check_usable()
        await self.board.set_up(self, input_setup(self.pin, pull_up))
        self.direction = "input"

    async def _as_input(self) -> None:
        if self.direction != "input":
            await self.configure_input()


class AnalogInput:
    """An analog input A0-A5: 10-bit conversions against AVCC."""

    def __init__(self, board: BoardCore, pin: AnalogPin, vref: float = p.VCC_MV / 1000) -> None:
        board.model.require(pin, Function.ANALOG_INPUT)
        self.board = board
        self.pin = pin
        self.vref = vref

    def __repr__(self) -> str:
        return f"<AnalogInput {self.pin.name} on {self.board}>"

    async def read(self) -> int:
        """One conversion, raw: 0-1023 (10 bits, 0 V to ``vref``)."""
        reply = await self.board.request(p.AnalogRead(int(self.pin)))
        return reply.value

    async def read_volts(self) -> float:
        """One conversion in volts: the raw value scaled by ``vref`` (5.0 V, the Uno's
        AVCC, unless the handle was made with another reference)."""
        return await self.read() * self.vref / 1024

    def watch(
        self,
        deadband: int,
        *,
        buffer: int = DEFAULT_CHANGE_BUFFER,
        callback: Callable[[AnalogMove], None] | None = None,
    ) -> AbstractAsyncContextManager[AnalogChanges]:
        """``async with a0.watch(deadband=8) as moves: async for move in moves: ...``: the
        board reports each move by more than ``deadband`` counts (1-1023) until the block
        ends (extension; :mod:`arduinoio_async.board.changes` gives the rules)."""
        return watch_analog(self.board, self.pin, deadband, buffer, callback)

    async def changes(
        self, deadband: int, *, buffer: int = DEFAULT_CHANGE_BUFFER
    ) -> AsyncGenerator[AnalogMove, None]:
        """``async for move in board.analog(A0).changes(deadband=8):`` each move as it
        happens; leaving the loop unsubscribes when the generator is closed."""
        async with self.watch(deadband, buffer=buffer) as moves:
            async for move in moves:
                yield move

    def on_change(
        self, callback: Callable[[AnalogMove], None], deadband: int
    ) -> AbstractAsyncContextManager[AnalogChanges]:
        """``async with a0.on_change(cb, deadband=8):`` calls ``cb(move)`` for each move
        while the block runs (on the link's reader: keep it short; exceptions are logged)."""
        return self.watch(deadband, callback=callback)


class PulseOutput(PinHandle):
    """Servo pulses every 20 ms; subclasses fix the pins and the resolution.

    Each output has its own pulse limits, :attr:`min_us`-:attr:`max_us`: 1,000-2,000 us
    unless set up with others (``board.servo(D9, min_us=500, max_us=2500)``), because
    every hobby servo takes that range, while a wider one drives many into their end
    stops.  The board accepts 500-2,500 us; widths outside the limits are refused here.
    """

    STEP_US = 1

    def __init__(self, board: BoardCore, pin: DigitalPin) -> None:
        super().__init__(board, pin)
        self.pulse_us: int = 0
        #: The narrowest and widest pulse this output sends (set_angle's 0 and 180 degrees).
        self.min_us: int = p.SERVO_DEFAULT_MIN_US
        self.max_us: int = p.SERVO_DEFAULT_MAX_US

    def set_limits(self, min_us: int, max_us: int) -> None:
        """Allow widths ``min_us``-``max_us`` (within the board's 500-2,500 us)."""
        if not p.PULSE_MIN_US <= min_us < max_us <= p.PULSE_MAX_US:
            raise ValueRangeError(
                "servo pulse limits (us)",
                (min_us, max_us),
                f"min < max, both within {p.PULSE_MIN_US}-{p.PULSE_MAX_US}",
            )
        self.min_us, self.max_us = int(min_us), int(max_us)

    def check_pulse(self, pulse_us: int) -> int:
        """Validate a pulse width (0 = no pulses) against this output's limits before it
        is sent."""
        if pulse_us == 0:
            return 0
        if not self.min_us <= pulse_us <= self.max_us:
            wider = (
                f" (set_limits or min_us/max_us widen it up to {p.PULSE_MIN_US}-{p.PULSE_MAX_US})"
                if (self.min_us, self.max_us) != (p.PULSE_MIN_US, p.PULSE_MAX_US)
                else ""
            )
            raise ValueRangeError(
                f"pulse width (us) on {self.pin.name}",
                pulse_us,
                f"0 (off) or {self.min_us}-{self.max_us}{wider}",
            )
        if pulse_us % self.STEP_US:
            raise ValueRangeError(
                "pulse width (us)", pulse_us, f"a multiple of {self.STEP_US} us on {self.ROLE}"
            )
        return pulse_us

    async def set_pulse(self, pulse_us: int) -> None:
        """Pulse width in microseconds, 1000-2000; 0 stops the pulses."""
        self.check_usable()
        pulse_us = self.check_pulse(int(pulse_us))
        reply = await self.board.request(p.PwmSet(self.pin, pulse_us))
        self.pulse_us = reply.pulse_us
        self.board.roles.amend(self, p.PwmConfig(self.pin, reply.pulse_us))

    async def set_angle(
        self, degrees: float, *, min_us: int | None = None, max_us: int | None = None
    ) -> None:
        """0-180 degrees mapped linearly onto ``min_us``-``max_us`` (by default the
        output's limits, :attr:`min_us`-:attr:`max_us`)."""
        if not 0 <= degrees <= 180:
            raise ValueRangeError("servo angle (degrees)", degrees, "0-180")
        min_us = self.min_us if min_us is None else min_us
        max_us = self.max_us if max_us is None else max_us
        pulse = min_us + (max_us - min_us) * degrees / 180
        await self.set_pulse(round(pulse / self.STEP_US) * self.STEP_US)

    async def stop(self) -> None:
        """Stop the pulses (the line stays low); the pin stays attached."""
        await self.set_pulse(0)


class Servo(PulseOutput):
    """Hardware servo PWM on D9 or D10: 1 us resolution."""

    ROLE = "servo PWM"
    STEP_US = 1


class SoftPwm(PulseOutput):
    """Software servo PWM on D2-D7: 1 us resolution (edges by timer compare match)."""

    ROLE = "software PWM"
    STEP_US = p.SOFT_PWM_STEP_US


class Counter(PinHandle):
    """An event counter on D2 (INT0) or D3 (INT1)."""

    ROLE = "event counter"

    async def read(self) -> int:
        """The edges counted since set-up or the last :meth:`reset` (32 bits, wrapping)."""
        self.check_usable()
        return (await self.board.request(p.CounterRead(self.pin))).count

    async def reset(self) -> int:
        """Clear the counter; returns the count it had (read and clear are atomic)."""
        self.check_usable()
        return (await self.board.request(p.CounterReset(self.pin))).count

    def reports(
        self, every: int, *, buffer: int = DEFAULT_CHANGE_BUFFER
    ) -> AbstractAsyncContextManager[CountReports]:
        """``async with counter.reports(every=100) as reports: async for r in reports:``
        the board reports the count every ``every`` counts (extension; 1-65535)."""
        self.check_usable()
        return watch_counter(self.board, self.pin, every, buffer)


@dataclass
class I2CBus:
    """The I2C bridge on A4 (SDA) / A5 (SCL)."""

    board: BoardCore
    speed: p.I2CSpeed

    @staticmethod
    def _check(address: int, register: int) -> None:
        if not 0 <= address <= 0x7F:
            raise ValueRangeError("I2C address", address, "7-bit, 0x00-0x7F")
        if not 0 <= register <= 0xFF:
            raise ValueRangeError("I2C register", register, "0x00-0xFF")

    async def read(self, address: int, register: int, length: int) -> bytes:
        """Read ``length`` (1-32) bytes from ``register`` of the device at ``address``."""
        self._check(address, register)
        if not 1 <= length <= p.I2C_MAX_LENGTH:
            raise ValueRangeError("I2C read length", length, f"1-{p.I2C_MAX_LENGTH}")
        return (await self.board.request(p.I2CRead(address, register, length))).data

    async def write(self, address: int, register: int, data: bytes) -> None:
        """Write up to 32 bytes to ``register`` of the device at ``address``."""
        self._check(address, register)
        if len(data) > p.I2C_MAX_LENGTH:
            raise ValueRangeError("I2C write length", len(data), f"0-{p.I2C_MAX_LENGTH}")
        await self.board.request(p.I2CWrite(address, register, bytes(data)))

    async def scan(self) -> list[int]:
        """The 7-bit addresses 0x08-0x77 a device acknowledges (the reserved ones left
        out), found by addressing each with an empty write (it sets no register's value;
        at most the register pointer of the device, to 0)."""
        found = []
        for address in range(0x08, 0x78):
            try:
                await self.board.request(p.I2CWrite(address, 0, b""))
            except I2CError as exc:
                if exc.code != p.ErrorCode.I2C_NACK_ADDRESS:
                    raise
            else:
                found.append(address)
        return found
