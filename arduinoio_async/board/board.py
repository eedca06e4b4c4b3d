"""One I/O board: connection set-up, and typed handles for every feature.

``Board`` sits on a :class:`~arduinoio_async.transport.Transport`.  It enforces the pins
its board described (:attr:`Board.model`; the Uno's Table III for an older image) and the
one-role-per-pin rule *before* anything is sent (the board would refuse too, but a
local error names the pins that can do it and costs no round trip).  The roles it gave are
recorded in its public :class:`~arduinoio_async.board.roles.PinRoles` table
(:attr:`Board.roles`), so that after a reset or replug the manager can replay them on the
fresh board and hand back the same ``Board`` and the same handles.  The failsafe and the
keepalive heartbeat live in :mod:`arduinoio_async.board.failsafe`; waiting for a boot of the
board and telling boots apart in :mod:`arduinoio_async.board.boot`.
"""

from __future__ import annotations

import logging
import random
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import asynccontextmanager
from typing import Any, Self, TypeVar

import anyio
import anyio.abc
import anyio.lowlevel
import anyio.to_thread

from .. import protocol as p
from .._schemes import opener_for
from ..errors import (
    BoardDisconnectedError,
    BoardSilentError,
    FailsafeTrippedError,
    LinkError,
    ProtocolError,
    ValueRangeError,
)
from ..protocol.boards import UNO_R3, BoardModel
from ..protocol.pins import DigitalPin, Function
from ..transport import (
    DEFAULT_TIMEOUT,
    TraceHook,
    Transport,
    open_serial_stream,
    tick_holding_bridge,
)
from ._encoder_methods import EncoderMethods
from ._features import FeatureMethods
from ._motor_methods import MotorMethods
from ._pulse_in_methods import PulseInMethods
from ._sonar_methods import SonarMethods
from ._spi_methods import SpiMethods
from ._stepper_methods import StepperMethods
from ._stream_methods import StreamMethods
from .boot import (
    READY_TIMEOUT,
    check_same_board,
    explain_silence,
    read_id_retrying,
    start_link,
    wait_new_boot,
)
from .failsafe import Failsafe, FailsafeConfig, Recovery
from .handles import (
    Gpio,
    PinHandle,
)
from .model import read_board_model
from .motors import Motor
from .roles import PinRoles, RoleHolder
from .transactions import Transaction
from .watches import Watches

logger = logging.getLogger(__name__)

__all__ = ["READY_TIMEOUT", "Board"]

R = TypeVar("R", bound=p.Reply)
H = TypeVar("H", bound=PinHandle)


class Board(
    FeatureMethods,
    StreamMethods,
    MotorMethods,
    StepperMethods,
    EncoderMethods,
    SpiMethods,
    PulseInMethods,
    SonarMethods,
):
    """A connected arduinoio board.  Create it with :meth:`open` or :meth:`connect`."""

    def __init__(self, link: Transport, board_id: int, capabilities: p.ReadCapabilitiesReply):
        self._link: Transport | None = link
        self.board_id = board_id
        self.capabilities = capabilities
        #: The board's model (:mod:`arduinoio_async.board.model`), read at open; pins are
        #: checked against it before anything is sent.
        self.model: BoardModel = UNO_R3
        self.port = link.name
        self._roles = PinRoles(self)
        #: ``gpio(pin)`` hands out one Gpio per pin (until released), with a role or not yet.
        self._gpio: dict[DigitalPin, Gpio] = {}
        self.session = 0
        #: The session tag the board carried when this library last tagged it: 0 = a fresh
        #: boot nobody had tagged yet; any other value = an earlier program's tag (the board
        #: has not reset since that program connected).
        self.session_found = 0
        #: Low-latency mode as this library last set it (replayed after a reset).
        self.low_latency = False
        #: The change, counter and analog watches, restored after a reset with the roles.
        self.watches = Watches(self)
        self._failsafe: Failsafe[Board] = Failsafe(self)
        self._failsafe.listen(link)

    def __repr__(self) -> str:
        return f"<Board 0x{self.board_id:04X} on {self.port or 'nothing'}>"

    # ---- opening -------------------------------------------------------------------------

    @classmethod
    @asynccontextmanager
    async def open(
        cls,
        port: str,
        *,
        baudrate: int = p.DEFAULT_BAUD,
        timeout: float = DEFAULT_TIMEOUT,
        ready_timeout: float = READY_TIMEOUT,
        trace: TraceHook | None = None,
        low_latency: bool | None = None,
    ) -> AsyncIterator[Self]:
        """Open ``port`` (a device path or pyserial URL) and wait until the board answers.

        ``timeout`` is the default per-request timeout; ``ready_timeout`` bounds the wait
        for a board that resets when its port opens.  ``low_latency``: see
        :meth:`choose_low_latency` (None, the default, turns it on behind an Uno's 16U2
        bridge at 1,000,000 baud and up).  ``zenoh://0x0007[@endpoint]`` opens a board
        served on the network (:mod:`arduinoio_async.network`), whose server chose: the
        board layer does not know the network, so such an address goes to the opener
        registered for its scheme (:mod:`arduinoio_async.opener`).
        """
        remote = opener_for(port)
        if remote is not None:
            async with remote(port, timeout=timeout, ready_timeout=ready_timeout) as board:
                yield board
            return
        stream = await open_serial_stream(port, baudrate)
        try:
            link = await cls.start_link(
                stream, timeout=timeout, ready_timeout=ready_timeout, trace=trace, name=port
            )
        except BoardSilentError as silent:  # say why, as far as the board's bootloader tells
            raise await explain_silence(port, baudrate, silent) from None
        async with cls._serving(link) as board:
            await board.choose_low_latency(low_latency)
            yield board

    @classmethod
    @asynccontextmanager
    async def connect(
        cls,
        stream: anyio.abc.ByteStream,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        ready_timeout: float = READY_TIMEOUT,
        trace: TraceHook | None = None,
        name: str = "",
    ) -> AsyncIterator[Self]:
        """Use an already open byte stream (a memory link in tests, a custom transport)."""
        link = await cls.start_link(
            stream, timeout=timeout, ready_timeout=ready_timeout, trace=trace, name=name
        )
        async with cls._serving(link) as board:
            yield board

    @classmethod
    @asynccontextmanager
    async def _serving(cls, link: Transport) -> AsyncIterator[Self]:
        """The board on a link that answered: the link runs while the block does."""
        async with link:
            board = await cls.from_link(link)
            # In the transport's own task group: a task group around the caller's body
            # would wrap the caller's exceptions in ExceptionGroups.
            link.start_background(board.keepalive, link, name=f"arduinoio keepalive {link.name}")
            try:
                yield board
            finally:
                board._link = None

    @classmethod
    async def from_link(cls, link: Transport) -> Self:
        """A board on a started transport: reads its capabilities and ID, tags its session."""
        caps = await link.request(p.ReadCapabilities())
        board = cls(link, (await link.request(p.ReadId())).board_id, caps)
        await board._handshake(link)
        return board

    #: Wait for the board on a byte stream and wrap it in a (not yet started) transport
    #: (:func:`~arduinoio_async.board.boot.start_link`).
    start_link = staticmethod(start_link)
    """Wait for the board on a byte stream and wrap it in a transport that is not started yet
    (:func:`~arduinoio_async.board.boot.start_link`); a class attribute so that a subclass
    can open its link another way."""

    async def _handshake(self, link: Transport) -> None:
        """Check the protocol version, read the board's model, tag this boot (to detect
        resets)."""
        caps = self.capabilities
        if caps.protocol_version != p.PROTOCOL_VERSION:
            raise ProtocolError(
                f"{link.name} speaks protocol version {caps.protocol_version}; this library "
                f"speaks {p.PROTOCOL_VERSION} (update the firmware or the library)"
            )
        link.expected_id = self.board_id
        self.model = await read_board_model(link, caps)
        self.session_found = (await link.request(p.ReadStatus())).session
        self.session = random.randint(1, 0xFFFF)
        await link.request(p.SetSession(self.session))
        self.port = link.name

    async def adopt(self, link: Transport) -> None:
        """Make ``link`` (to a fresh boot of this board) the board's link.

        Used after a replug or a reset: the ID is checked (BoardIdChangedError for another
        board: nothing is replayed), the capabilities are read again, the session tagged,
        and every pin role replayed *before* the link is handed to callers (handles never
        see a half-restored board).  A failsafe this board armed is armed again *first*: a
        board that did not reboot may still be tripped (its host -- or, remotely, the
        server -- died while it stayed powered), and a tripped board refuses every output
        set-up until it is armed again; armed, it also guards the restore.
        """
        self._link = None
        await check_same_board(link, self.board_id)
        self.capabilities = await link.request(p.ReadCapabilities())
        await self._handshake(link)
        await self._failsafe.arm_on(link)
        await self._restore_on(link)
        self._failsafe.listen(link)
        self._link = link

    def detach(self, link: Transport | None = None) -> None:
        """Forget the link (if it is ``link``); calls fail with BoardDisconnectedError."""
        if link is None or self._link is link:
            self._link = None

    # ---- plumbing ---------------------------------------------------------------------------

    @property
    def link(self) -> Transport:
        """The current transport; raises BoardDisconnectedError while there is none."""
        if self._link is None:
            raise BoardDisconnectedError(f"board 0x{self.board_id:04X} is not connected")
        return self._link

    @property
    def connected(self) -> bool:
        """Whether the board has a link that is not closed (False after a disconnect, until
        the manager attaches a new one)."""
        return self._link is not None and self._link.state.value != "closed"

    async def request(self, request: p.Request[R], *, timeout: float | None = None) -> R:
        """Send a raw protocol request and return its verified reply."""
        try:
            return await self.link.request(request, timeout=timeout)
        except FailsafeTrippedError:
            self._failsafe.notice_trip()  # the refusal may be the first news of the trip
            raise

    def transaction(self) -> Transaction:
        """Requests run back to back in one frame: ``async with board.transaction() as tx:
        d3 = tx.add(p.GpioRead(D3))`` (extension; see :mod:`arduinoio_async.board.transactions`)."""
        return Transaction(self)

    # ---- pin roles ---------------------------------------------------------------------------

    @property
    def roles(self) -> PinRoles:
        """Which pin holds which role: ``board.roles[D4].handle``, ``.setup``, ``.role``.

        Read it freely (the monitor shows it); the handles and the board change it.
        """
        return self._roles

    async def set_up(self, handle: RoleHolder, setup: p.Request[Any]) -> None:
        """Give ``handle`` its pin by sending ``setup``, and record it in :attr:`roles`.

        What the typed handles do when they take a pin or change its direction.  A pin
        another handle holds is refused with :class:`PinRoleError` before anything is
        sent; the claim is made before the request goes out, so two tasks asking for the
        same pin at once cannot both reach the board, and is undone if the board refuses.
        """
        roles = self._roles
        previous = roles.claim(handle, setup)
        try:
            await self.request(setup)
        except BaseException:
            roles.withdraw(handle, previous)
            raise

    async def release(self, pin: DigitalPin) -> None:
        """End whatever role ``pin`` has, on the board and here."""
        self.model.require(pin, Function.DIGITAL_INPUT)
        await self.request(p.PinRelease(int(pin)))
        handle = self._roles.release(pin)
        for other in getattr(handle, "other_pins", ()):  # an encoder's pin B goes with A
            self._roles.release(other)
        holder = getattr(handle, "encoder", None)  # ... and its pin A with B
        if holder is not None:
            self._roles.release(holder.pin)
        owner = getattr(handle, "owner", None)  # an SPI pin: the whole bus goes
        if owner is not None:
            self._roles.release(owner.pin)
            for other in owner.other_pins:
                self._roles.release(other)
        gpio = self._gpio.pop(pin, None)
        if gpio is not None:
            gpio.direction = None
            gpio.released = True

    async def restore(self) -> None:
        """Replay every pin role, the I2C speed and the watches on a board that reset."""
        await self._restore_on(self.link)

    async def _restore_on(self, link: Transport) -> None:
        for setup in self._roles.setups():
            await link.request(setup)
        if self.low_latency:
            await link.request(p.SetLowLatency(True))
        await self.watches.restore_on(link)  # after the roles: a watch needs its pin's role

    async def choose_low_latency(self, choice: bool | None) -> bool:
        """Set the low-latency mode as ``choice`` says; None decides by the link.

        None turns it on when it pays: the port is behind a bridge that holds replies for
        a timer tick (an Uno's ATmega16U2, known by its USB IDs:
        :data:`~arduinoio_async.transport.TICK_HOLDING_BRIDGES`), the link runs at
        1,000,000 baud or faster (at 115200 the filler alone outlasts the tick), and the
        firmware has the mode.  Anything else -- another bridge, a pseudo-terminal, a
        network URL -- leaves it off.  The choice is always sent to a board that has the
        mode: the board keeps it while its port is closed, so a previous program may have
        left it on.  Returns whether it is on.
        """
        supported = bool(self.capabilities.features & p.Feature.LOW_LATENCY)
        if choice is None:
            choice = (
                supported
                and self.capabilities.baud >= p.DEFAULT_BAUD
                and await anyio.to_thread.run_sync(tick_holding_bridge, self.port) is not None
            )
            if choice:
                logger.info("%r: behind a 16U2 bridge: low-latency mode on", self)
        if supported or choice:
            await self.set_low_latency(choice)  # without the mode, True raises ProtocolError
        return choice

    async def set_low_latency(self, enabled: bool = True) -> None:
        """Ask the board to pad each burst of replies with filler bytes (an extension).

        Behind the Uno's stock USB bridge (the 16U2's arduino-usbserial) a reply waits
        for the bridge's 4.096 ms timer tick unless more than 96 bytes wait, so the board
        sends filler until reply and filler make 97 bytes; the decoder drops filler.  It
        costs 97 byte times of the board-to-host line per burst (485 us at 2 Mbaud,
        970 us at 1 Mbaud), so it pays from 1 Mbaud up and only behind such a bridge.
        Off after every boot of the board; this board replays it after a reset or a
        reconnect.  Raises ProtocolError when the firmware does not announce it.
        """
        if not self.capabilities.features & p.Feature.LOW_LATENCY:
            raise ProtocolError(
                f"board 0x{self.board_id:04X}'s firmware has no low-latency mode "
                "(capabilities: no LOW_LATENCY feature bit); update the firmware"
            )
        await self.request(p.SetLowLatency(enabled))
        self.low_latency = enabled

    # ---- misc ------------------------------------------------------------------------------

    async def read_id(self) -> int:
        """The board ID (0x0000-0xFFFF) stored in the board's EEPROM, read from the board
        now (:attr:`board_id` is the one read when the link opened)."""
        return (await self.request(p.ReadId())).board_id

    async def write_id(self, board_id: int, *, deadline: float = READY_TIMEOUT) -> None:
        """Store a new board ID in EEPROM; it survives resets.

        If the reply is lost, the write may or may not have happened: the link accepts
        either ID when it resyncs, and the ID is read back (within ``deadline``) to settle
        it; raises if the board kept the old ID, BoardTimeoutError if it never answered.
        """
        if not 0 <= board_id <= 0xFFFF:
            raise ValueRangeError("board ID", board_id, "0x0000-0xFFFF")
        link = self.link
        try:
            await link.request(p.WriteId(board_id))
        except BoardDisconnectedError:
            raise
        except LinkError:
            if await read_id_retrying(link, deadline) != board_id:
                raise
        self.board_id = board_id
        link.expected_id = board_id

    async def temperature(self) -> float:
        """Chip temperature in degrees C (datasheet-typical calibration)."""
        return (await self.request(p.ReadTemperature())).celsius

    async def status(self) -> p.ReadStatusReply:
        """The board's status flags (failsafe armed or tripped, a stream running) and its
        session tag, which is 0 after every boot: how a reset is noticed."""
        return await self.request(p.ReadStatus())

    async def reset(self, *, restore: bool = False, deadline: float = READY_TIMEOUT) -> None:
        """Reset the board through its watchdog and wait until it answers again.

        Pin roles and watches are lost on the board; the local records are kept, and with
        ``restore=True`` (or a later :meth:`restore`) they are set up again (a watch's
        ``async for`` waits meanwhile).
        """
        await self.request(p.Reset())
        await self.wait_rebooted(deadline=deadline)
        if restore:
            await self.restore()

    async def wait_rebooted(self, *, deadline: float = READY_TIMEOUT) -> None:
        """Poll until the board answers with a fresh boot's session 0, then tag it again."""
        link = self.link
        await wait_new_boot(link, self.session, deadline=deadline, who=repr(self))
        await self._handshake(link)

    # ---- failsafe and keepalive (extension; :mod:`arduinoio_async.board.failsafe`) ---------

    @property
    def failsafe(self) -> FailsafeConfig | None:
        """The armed failsafe (timeout and safe states), or None when it is not armed."""
        return self._failsafe.config

    @property
    def failsafe_tripped(self) -> bool:
        """True once the board reported that its failsafe fired, until it is armed again."""
        return self._failsafe.tripped

    @failsafe_tripped.setter
    def failsafe_tripped(self, tripped: bool) -> None:
        self._failsafe.tripped = tripped

    def on_failsafe(self, callback: Callable[[Board], None]) -> Callable[[], None]:
        """Call ``callback(board)`` when the board reports that its failsafe fired."""
        return self._failsafe.on_trip(callback)

    async def arm_failsafe(
        self, timeout_ms: int, safe_states: Mapping[PinHandle | Motor, bool | float]
    ) -> None:
        """Arm the board's link watchdog.

        ``safe_states`` maps output handles to what they do when the host falls silent for
        ``timeout_ms``: a level for digital outputs, a pulse width in us (0 = no pulses)
        for servo and soft-PWM outputs, a duty 0.0-1.0 for duty PWM; a :class:`Motor`'s
        safe state is stopped (every PWM pin it has at duty 0) whatever its value.  The
        keepalive feeds the watchdog while this process runs; a killed process, a pulled
        cable or a blocked event loop lets it fire.
        """
        await self._failsafe.arm(timeout_ms, safe_states)

    async def disarm_failsafe(self) -> None:
        """Stop the board's link watchdog: a silent host no longer puts the outputs in
        their safe states (call it before a planned pause of the program)."""
        await self._failsafe.disarm()

    async def rearm_failsafe(self, *, restore: bool = True) -> None:
        """After a trip: arm again and (by default) put every output back as it was."""
        await self._failsafe.rearm(restore=restore)

    def heartbeat_interval(self) -> float:
        """How long the link may stay idle before the keepalive polls the board."""
        return self._failsafe.heartbeat_interval()

    async def keepalive(
        self, link: Transport, *, on_reset: Recovery | None = None, on_trip: Recovery | None = None
    ) -> None:
        """Keep ``link`` alive until it closes: status polls while it is idle feed the
        failsafe and notice a trip no event reported, or (``on_reset``) a board that reset
        by itself; a failing recovery is logged and tried at the next poll, never raised."""
        await self._failsafe.keepalive(link, on_reset=on_reset, on_trip=on_trip)
