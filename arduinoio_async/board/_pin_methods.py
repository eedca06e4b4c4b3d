"""The board's pin-handle factories (``gpio``, ``digital_output``, ``digital_input``,
``analog``, ``counter``, ``i2c``), mixed into :class:`~arduinoio_async.board.Board`.

Kept apart from ``board.py`` by idea: the board opens and keeps its link; these only turn
a pin and its checks (Table III, one role per pin) into a handle, through the
:class:`~arduinoio_async.board._core.BoardCore` members (``roles``, ``set_up``,
``request``) the handles use themselves.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar, cast

from .. import protocol as p
from ..errors import PinRoleError
from ..protocol.pins import AnalogPin, CounterPin, DigitalPin, Function
from .handles import (
    AnalogInput,
    Counter,
    DigitalInput,
    DigitalOutput,
    Gpio,
    I2CBus,
    PinHandle,
    input_setup,
    output_setup,
)

if TYPE_CHECKING:
    from ._core import BoardCore

__all__ = ["PinMethods"]

H = TypeVar("H", bound=PinHandle)


class PinMethods:
    """The typed handles of a board's pins."""

    #: ``gpio(pin)`` hands out one Gpio per pin (until released), with a role or not yet.
    _gpio: dict[DigitalPin, Gpio]

    @property
    def _board(self) -> BoardCore:
        return cast("BoardCore", self)

    def _new_handle(
        self, pin: object, function: Function, factory: Callable[[BoardCore, DigitalPin], H]
    ) -> H:
        self._board.model.require(pin, function)
        assert isinstance(pin, DigitalPin)
        handle = factory(cast("BoardCore", self), pin)
        self._board.roles.check_free(handle)
        return handle

    # ---- handles -----------------------------------------------------------------------------

    def gpio(self, pin: DigitalPin) -> Gpio:
        """A digital pin that configures itself on first use (output on write, input on read)."""
        self._board.model.require(pin, Function.DIGITAL_OUTPUT)
        handle = self._gpio.get(pin)
        if handle is None:
            handle = Gpio(cast("BoardCore", self), pin)
            self._board.roles.check_free(handle)
            self._gpio[pin] = handle
        return handle

    async def digital_output(self, pin: DigitalPin, *, initial: bool = False) -> DigitalOutput:
        """Make ``pin`` an output that starts at ``initial`` (no glitch to the other level).

        The role is recorded and replayed after a reset.  Raises PinCapabilityError for a
        pin that cannot be a digital output, PinRoleError when another handle holds it.
        """
        handle = self._new_handle(pin, Function.DIGITAL_OUTPUT, DigitalOutput)
        await self._board.set_up(handle, output_setup(handle.pin, initial))
        return handle

    async def digital_input(self, pin: DigitalPin, *, pull_up: bool = False) -> DigitalInput:
        """Make ``pin`` an input, with the internal pull-up (20-50 kOhm to 5 V) if asked.

        The board latches rising and falling edges between reads (:meth:`DigitalInput.read
        <arduinoio_async.board.handles.DigitalInput.read>`).  Raises PinCapabilityError or
        PinRoleError as :meth:`digital_output` does.
        """
        handle = self._new_handle(pin, Function.DIGITAL_INPUT, DigitalInput)
        await self._board.set_up(handle, input_setup(handle.pin, pull_up))
        return handle

    def analog(self, pin: AnalogPin) -> AnalogInput:
        """An analog input (no configuration needed); A4/A5 are busy while I2C is on."""
        if self._board.roles.i2c is not None and self._board.model.can(pin, Function.I2C):
            raise PinRoleError(pin.name, "I2C", "analog input")
        return AnalogInput(cast("BoardCore", self), pin)

    async def read_analog_all(self) -> tuple[int, ...]:
        """All six analog inputs, A0 first, in one request."""
        return (await self._board.request(p.AnalogReadAll())).values

    async def counter(self, pin: CounterPin, *, edge: p.Edge = p.Edge.RISING) -> Counter:
        """An event counter on D2/D3 counting rising or falling edges, from zero."""
        handle = self._new_handle(pin, Function.COUNTER, Counter)
        await self._board.set_up(handle, p.CounterConfig(handle.pin, p.Edge(edge)))
        return handle

    async def i2c(self, speed: p.I2CSpeed = p.I2CSpeed.KHZ_100) -> I2CBus:
        """The I2C bridge on A4/A5 at 100 or 400 kHz."""
        reply = await self._board.request(p.I2CConfig(p.I2CSpeed(speed)))
        bus = I2CBus(cast("BoardCore", self), reply.speed)
        self._board.roles.set_i2c(bus)
        return bus
