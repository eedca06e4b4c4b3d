"""Which client holds which pin of a served board, so one client cannot take another's.

The board enforces one role *class* per pin (a PWM set-up on a GPIO pin is refused with
``PIN_BUSY``) but lets any host turn a GPIO output into an input: on its own serial line
there is one host, and the library refuses that change before sending it
(:class:`~arduinoio_async.errors.PinRoleError`).  Several clients of one served board
do not see each other's handles, so the server keeps the rule between them: a set-up of
a pin that another *live* client holds in another role, or a release of such a pin, is
refused with the board's own ``PIN_BUSY`` error reply, as a local board refuses a
set-up of another class.  A set-up in the role the pin already has is accepted and
shared (a restarted controller sets its pins up again; two clients may read one input);
a vanished client's pins stay configured on the board but are held by nobody.

A claim is recorded when the set-up is admitted (in arrival order, before it reaches
the link), so two clients asking for one pin at once cannot both get it, and undone if
the board refuses it (not when it timed out: it may have been carried out, and the
client's retry may be admitted already).  Set-ups inside a transaction count as well.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .. import protocol as p

__all__ = ["PinHolders", "role_of", "roles_of"]

#: Requests that give a pin a role or take it away.
CLAIMS: frozenset[type[p.Request[Any]]] = frozenset(
    {
        p.GpioConfig,
        p.PwmConfig,
        p.CounterConfig,
        p.EncoderConfig,
        p.SonarConfig,
        p.PulseInConfig,
        p.SpiConfig,
        p.I2CBlock,
        p.PinRelease,
        p.Transaction,
        p.StepperConfig,
        p.StepperLimit,
    }
)

#: The claim key of I2C block slot ``s`` is ``I2C_BLOCK_KEY - s`` (below the encoder
#: slots' -1..-ENCODER_SLOTS): the blocks a stream reads are one client's.
I2C_BLOCK_KEY = -32
#: The claim key of sonar slot ``s`` is ``SONAR_KEY - s`` (between the encoders' and the
#: I2C blocks'): a set-up of a slot in use reconfigures it on the board.
SONAR_KEY = -16
#: The claim key of pulse input slot ``s`` is ``PULSE_IN_KEY - s`` (between the sonars'
#: and the I2C blocks').
PULSE_IN_KEY = -24


def role_of(request: p.Request[Any]) -> tuple[int, str] | None:
    """(pin, role) that ``request`` sets up, (pin, "") for a release, else None."""
    if isinstance(request, p.GpioConfig):
        if request.flags & p.GpioFlags.OUTPUT:
            return request.pin, "digital output"
        pull_up = request.flags & p.GpioFlags.PULL_UP
        return request.pin, "digital input with pull-up" if pull_up else "digital input"
    if isinstance(request, p.PwmConfig):
        return request.pin, "pulse output"
    if isinstance(request, p.CounterConfig):
        return request.pin, f"counter ({request.edge.name.lower()} edges)"
    if isinstance(request, p.PinRelease):
        return request.pin, ""
    return None


def roles_of(request: p.Request[Any]) -> list[tuple[int, str]]:
    """Every (pin, role) ``request`` sets up or releases: :func:`role_of`'s, a stepper's
    pins (its step and direction pins, a limit switch), and an encoder's: its set-up claims
    both its pins and its slot (key ``-1 - slot``: a set-up of a slot in use reconfigures it
    on the board), in a role naming both pins, so only the same encoder is shared; a pulse
    input's pin and slot likewise."""
    if isinstance(request, p.StepperConfig):
        n = request.index
        return [
            (request.step_pin, f"stepper {n}'s step pin"),
            (request.dir_pin, f"stepper {n}'s direction pin"),
        ]
    if isinstance(request, p.StepperLimit):
        return [(request.pin, f"stepper {request.index}'s limit switch")] if request.pin else []
    if isinstance(request, p.EncoderConfig):
        role = f"quadrature encoder D{request.pin_a}/D{request.pin_b} (slot {request.slot})"
        return [(request.pin_a, role), (request.pin_b, role), (-1 - request.slot, role)]
    if isinstance(request, p.SonarConfig):
        role = f"sonar D{request.trigger}/D{request.echo} (slot {request.slot})"
        return [(request.trigger, role), (request.echo, role), (SONAR_KEY - request.slot, role)]
    if isinstance(request, p.PulseInConfig):
        # the pin and the slot: a set-up of a slot in use moves it on the board
        role = f"pulse-width input D{request.pin} (slot {request.slot})"
        return [(request.pin, role), (PULSE_IN_KEY - request.slot, role)]
    if isinstance(request, p.SpiConfig):
        # the SPI bridge claims D11-D13 and its chip select in one role naming the chip
        # select: another client's bus (another chip select) is refused on D11
        role = f"SPI (chip select D{request.cs})"
        return [(pin, role) for pin in (11, 12, 13, request.cs)]
    if isinstance(request, p.I2CBlock):
        if not request.length:  # freeing the slot releases it
            return [(I2C_BLOCK_KEY - request.slot, "")]
        role = (
            f"I2C stream block {request.length} bytes at 0x{request.register:02X} of "
            f"0x{request.address:02X} (slot {request.slot})"
        )
        return [(I2C_BLOCK_KEY - request.slot, role)]
    found = role_of(request)
    return [] if found is None else [found]


@dataclass
class _Held:
    role: str
    clients: set[str] = field(default_factory=set)


@dataclass
class PinHolders:
    """The pins of one served board that live clients hold, and in which role."""

    pins: dict[int, _Held] = field(default_factory=dict)

    def claim(self, client: str, request: p.Request[Any]) -> tuple[p.ErrorCode, str] | None:
        """Record what ``request`` of ``client`` claims; return the refusal instead (its
        code and why: the role another client holds the pin or slot in), or None.

        A held slot is checked before any pin and refused with ``SLOT_BUSY``, not
        ``PIN_BUSY``: a client that did not name the slot takes the next one on that code
        (the slots of a class are the board's, shared by every client, and a client sees
        only its own handles), while a pin held by another client is a real conflict.
        """
        wanted = [role for item in self._requests(request) for role in roles_of(item)]
        for pin, role in sorted(wanted, key=lambda item: item[0] >= 0):
            why = self._conflict(client, pin, role)
            if why is not None:
                code = p.ErrorCode.PIN_BUSY if pin >= 0 else p.ErrorCode.SLOT_BUSY
                return code, why
        for pin, role in wanted:
            self._take(client, pin, role)
        return None

    def refused(self, client: str, request: p.Request[Any]) -> None:
        """The board refused ``request``: ``client`` holds nothing through it."""
        for found in (role for item in self._requests(request) for role in roles_of(item)):
            held = self.pins.get(found[0])
            if held is not None and held.role == found[1]:
                held.clients.discard(client)
                if not held.clients:
                    del self.pins[found[0]]

    def client_gone(self, client: str) -> None:
        """A vanished client holds nothing; its pins keep their roles on the board."""
        for pin, held in list(self.pins.items()):
            held.clients.discard(client)
            if not held.clients:
                del self.pins[pin]

    @staticmethod
    def _requests(request: p.Request[Any]) -> list[p.Request[Any]]:
        return p.readable_items(request.items) if isinstance(request, p.Transaction) else [request]

    def _conflict(self, client: str, pin: int, role: str) -> str | None:
        held = self.pins.get(pin)
        if held is None or not held.clients - {client} or held.role == role:
            return None
        if pin >= 0:
            name = f"D{pin}"
        elif pin <= I2C_BLOCK_KEY:
            name = f"I2C block slot {I2C_BLOCK_KEY - pin}"
        elif pin <= PULSE_IN_KEY:
            name = f"pulse input slot {PULSE_IN_KEY - pin}"
        elif pin <= SONAR_KEY:
            name = f"sonar slot {SONAR_KEY - pin}"
        else:
            name = f"encoder slot {-1 - pin}"
        return f"{name} is a {held.role} of another client"

    def _take(self, client: str, pin: int, role: str) -> None:
        held = self.pins.get(pin)
        if not role:  # a release: the pin is free (no other client held it)
            self.pins.pop(pin, None)
        elif held is not None and held.role == role:
            held.clients.add(client)
        else:
            self.pins[pin] = _Held(role, {client})
