"""Find boards by their 16-bit ID and keep them working through resets and replugs.

Theory of operation
-------------------
The manager owns a task group.  A *scan* collects candidate ports -- USB serial devices
from pyserial's port listing (by vendor/product ID), explicit paths, glob patterns, the
``ARDUINOIO_PORTS`` environment variable, and the boards local programs announce (a
running ``arduinoio sim``) -- and probes every candidate that is not in
use *concurrently*, each with a deadline long enough for a Uno's auto-reset on open.  A
port that does not answer an ID request is closed at once and not probed again until it
disappears from the candidates and comes back, so foreign devices are left alone.  A port
that could not be opened at all (another process holds it, it is not there yet, no
permission) sent and heard nothing: it is tried again at every scan, and why it is
skipped is logged once per reason, not at every scan.

Each board that answers gets a supervisor task (:mod:`._supervisor`, shared with the
remote client): it runs the transport, re-tags the board's session and replays its pin
configuration whenever it meets a fresh boot of the board, and polls the board's status
on a heartbeat.  A session that reads 0 (or anything but what was set) means the board
reset by itself; it is restored on the spot.  When the port is lost, pending calls fail
at once (the transport does that), the :class:`Board` object is detached, and the scan
loop goes on looking; when the board turns up again on any port, the *same* ``Board``
and its handles are re-attached after the restore.
"""

from __future__ import annotations

import argparse
import glob
import logging
import os
from collections.abc import Callable, Iterable, Sequence
from contextlib import AsyncExitStack
from dataclasses import dataclass, field
from functools import partial

import anyio
import anyio.abc
from serial.tools import list_ports

from . import protocol as p
from ._port_registry import registered_ports
from ._supervisor import (
    Events,
    LinkOutcome,
    ManagerEvent,
    attach_board,
    retry_forever,
    supervise_link,
)
from .board import READY_TIMEOUT, Board
from .errors import (
    ArduinoIOError,
    BoardNotFoundError,
    DuplicateBoardError,
)
from .transport import DEFAULT_TIMEOUT, Transport, open_serial_stream
from .transport._bridges import DISCOVERY_IDS
from .transport._ready import wait_ready

__all__ = [
    "ENV_PORTS",
    "USB_IDS",
    "BoardManager",
    "ManagerEvent",
    "ProbeResult",
    "attach_board",
    "candidate_ports",
]

logger = logging.getLogger(__name__)

#: Deployments list ports here: paths or glob patterns separated by ``os.pathsep`` or ",".
ENV_PORTS = "ARDUINOIO_PORTS"

#: (vendor ID, product ID or None for any) of the USB devices probed: the bridges boards
#: ship with (``transport._bridges.BRIDGES``) and Arduino's other devices.
USB_IDS: tuple[tuple[int, int | None], ...] = DISCOVERY_IDS

RESCAN_INTERVAL = 1.0


@dataclass(frozen=True, slots=True)
class ProbeResult:
    """What one port answered to a probe."""

    port: str
    board_id: int | None = None
    capabilities: p.ReadCapabilitiesReply | None = None
    error: str = ""

    @property
    def ok(self) -> bool:
        """A board answered and was taken into service (no error on the way)."""
        return self.board_id is not None and not self.error


def add_ports_option(parser: argparse.ArgumentParser) -> None:
    """``--ports PATH_OR_GLOB`` (repeatable) into ``args.ports``: the ``patterns`` of a
    :class:`BoardManager`, for every command that scans (board commands, serve, monitor)."""
    parser.add_argument(
        "--ports",
        action="append",
        default=[],
        metavar="PATH_OR_GLOB",
        help=f"also probe these ports (repeatable; {ENV_PORTS} works too)",
    )


def _env_patterns() -> list[str]:
    raw = os.environ.get(ENV_PORTS, "")
    return [part for chunk in raw.split(os.pathsep) for part in chunk.split(",") if part]


def _usb_ports() -> list[str]:
    found = []
    for info in list_ports.comports():
        for vid, pid in USB_IDS:
            if info.vid == vid and (pid is None or info.pid == pid):
                found.append(info.device)
                break
    return found


def candidate_ports(
    ports: Iterable[str] = (),
    patterns: Iterable[str] = (),
    *,
    usb: bool = True,
    env: bool = True,
    registered: bool = True,
) -> list[str]:
    """Ports worth probing, in a stable order without duplicates.

    ``registered``: also the boards programs on this machine announce (a running
    ``arduinoio sim``, see :mod:`arduinoio_async._port_registry`).
    """
    seen: dict[str, None] = {}
    for port in ports:
        seen[port] = None
    for pattern in [*patterns, *(_env_patterns() if env else [])]:
        matches = sorted(glob.glob(pattern)) if glob.has_magic(pattern) else [pattern]
        for port in matches:
            seen[port] = None
    if usb:
        for port in _usb_ports():
            seen[port] = None
    if registered:
        for entry in registered_ports():
            seen[entry.port] = None
    return list(seen)


@dataclass
class _Known:
    """A port the manager has dealt with: held by a board, or known not to be one."""

    result: ProbeResult
    held: bool = False


@dataclass
class BoardManager:
    """Boards by ID.  ``async with BoardManager() as boards: left = await boards.get(1)``."""

    ports: Sequence[str] = ()
    patterns: Sequence[str] = ()
    usb: bool = True
    env: bool = True
    #: Also the boards local programs announce (``arduinoio sim``): see candidate_ports.
    registered: bool = True
    baudrate: int = p.DEFAULT_BAUD
    timeout: float = DEFAULT_TIMEOUT
    #: Each board's low-latency mode when first attached: see Board.choose_low_latency
    #: (None: on behind an Uno's 16U2 bridge at 1,000,000 baud and up).
    low_latency: bool | None = None
    probe_deadline: float = READY_TIMEOUT
    #: Seconds between background scans for new or returning boards; None scans only
    #: on entry and on explicit ``scan()`` calls (one-shot tools).
    rescan_interval: float | None = RESCAN_INTERVAL
    _boards: dict[int, Board] = field(default_factory=dict, init=False)
    _known: dict[str, _Known] = field(default_factory=dict, init=False)
    _duplicates: dict[int, set[str]] = field(default_factory=dict, init=False)
    _extra_ports: list[str] = field(default_factory=list, init=False)
    _events: Events = field(default_factory=lambda: Events(logger), init=False)
    _task_group: anyio.abc.TaskGroup | None = field(default=None, init=False)
    _exit_stack: AsyncExitStack | None = field(default=None, init=False)
    _scan_lock: anyio.Lock = field(default_factory=anyio.Lock, init=False)
    #: Board ID -> the port whose supervisor owns it (set the moment a probe finds it).
    _claims: dict[int, str] = field(default_factory=dict, init=False)
    #: Ports whose board answered the ID probe but failed its handshake, with the reason
    #: (a protocol-version mismatch, a port lost mid-handshake).  Reported by ``probed()``
    #: without keeping the port from being probed again at the next scan.
    _failed: dict[str, ProbeResult] = field(default_factory=dict, init=False)
    #: Ports that could not be opened, with the reason last logged (logged once per reason).
    _unopened: dict[str, str] = field(default_factory=dict, init=False)

    async def __aenter__(self) -> BoardManager:
        # Through an exit stack: if the first scan raises, the task group is still
        # exited in this task (trio insists: "Nursery stack corrupted" otherwise).
        stack = AsyncExitStack()
        try:
            self._task_group = await stack.enter_async_context(anyio.create_task_group())
            await self.scan()
            if self.rescan_interval is not None:
                rescan = partial(
                    retry_forever,
                    self.scan,
                    pause=self.rescan_interval,
                    what="scan",
                    log=logger,
                    pause_first=True,
                )
                self._task_group.start_soon(rescan, name="arduinoio manager scan")
        except BaseException:
            if self._task_group is not None:
                self._task_group.cancel_scope.cancel()
            self._task_group = None
            await stack.aclose()
            raise
        self._exit_stack = stack
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        stack, self._exit_stack = self._exit_stack, None
        if stack is not None:
            if self._task_group is not None:
                self._task_group.cancel_scope.cancel()
            self._task_group = None
            await stack.aclose()
        for board in self._boards.values():
            board.detach()

    # ---- public API ------------------------------------------------------------------------

    def present(self) -> dict[int, Board]:
        """Boards connected now, by ID."""
        self._rekey()
        return {bid: board for bid, board in self._boards.items() if board.connected}

    def probed(self) -> dict[str, ProbeResult]:
        """What every port answered at its last probe (a failed handshake with its reason)."""
        return {
            **self._failed,
            **{port: known.result for port, known in self._known.items()},
        }

    def add_port(self, port: str) -> None:
        """Also look at ``port`` from the next scan on (for example a new virtual Uno)."""
        if port not in self._extra_ports:
            self._extra_ports.append(port)

    def subscribe(self, callback: Callable[[ManagerEvent], None]) -> Callable[[], None]:
        """Call ``callback`` on every connect, disconnect, reset and duplicate."""
        return self._events.subscribe(callback)

    async def get(self, board_id: int, *, timeout: float | None = None) -> Board:
        """The board with ``board_id``, waiting up to ``timeout`` for it to connect.

        Raises :class:`DuplicateBoardError` when two ports answer with the ID, and
        :class:`BoardNotFoundError` (naming every port tried and its answer) on timeout.
        """
        if timeout is None:
            ports = [*self.ports, *self._extra_ports]
            if not self._known and not candidate_ports(
                ports, self.patterns, usb=self.usb, env=self.env, registered=self.registered
            ):
                raise BoardNotFoundError(board_id, {})  # nothing to wait for: say so now
            timeout = self.probe_deadline + (self.rescan_interval or 0.0)
        limit = timeout
        with anyio.move_on_after(limit):
            return await self.wait_connected(board_id)
        self._raise_duplicate(board_id)
        tried = {
            port: result.error or f"board 0x{result.board_id:04X}"
            for port, result in self.probed().items()
        }
        raise BoardNotFoundError(board_id, tried)

    async def wait_connected(self, board_id: int) -> Board:
        """Wait (without limit) until the board with ``board_id`` is connected."""
        while True:
            self._raise_duplicate(board_id)
            self._rekey()
            board = self._boards.get(board_id)
            if board is not None and board.connected:
                return board
            await self._events.changed()

    async def scan(self) -> dict[str, ProbeResult]:
        """Probe every new candidate port concurrently; return what each answered."""
        async with self._scan_lock:
            candidates = candidate_ports(
                [*self.ports, *self._extra_ports],
                self.patterns,
                usb=self.usb,
                env=self.env,
                registered=self.registered,
            )
            for gone in set(self._known) - set(candidates):
                if not self._known[gone].held:
                    del self._known[gone]  # it may come back as something else
            for gone in set(self._unopened) - set(candidates):
                del self._unopened[gone]
                self._failed.pop(gone, None)
            fresh = [port for port in candidates if port not in self._known]
            results: dict[str, ProbeResult] = {}
            async with anyio.create_task_group() as tg:
                for port in fresh:
                    tg.start_soon(self._probe_and_attach, port, results)
            return results

    # ---- internals --------------------------------------------------------------------------

    def _rekey(self) -> None:
        """File a board whose ID ``Board.write_id`` changed under its new ID (its claim
        on its port too), so that it is listed, found and restored as what it answers to."""
        for key, board in list(self._boards.items()):
            if board.board_id != key and self._boards.get(key) is board:
                del self._boards[key]
                self._boards[board.board_id] = board
                port = self._claims.pop(key, None)
                if port is not None:
                    self._claims[board.board_id] = port

    def _raise_duplicate(self, board_id: int) -> None:
        ports = self._duplicates.get(board_id)
        if ports:
            raise DuplicateBoardError(board_id, ports)

    async def _choose_modes(self, board: Board) -> None:
        await board.choose_low_latency(self.low_latency)

    async def _probe_and_attach(self, port: str, results: dict[str, ProbeResult]) -> None:
        try:
            stream = await open_serial_stream(port, self.baudrate)
        except ArduinoIOError as exc:
            # Not remembered as known: the next scan tries it again (see the docstring).
            results[port] = self._failed[port] = ProbeResult(port, error=str(exc))
            if self._unopened.get(port) != str(exc):
                self._unopened[port] = str(exc)
                logger.warning("skipping %s until a later scan: %s", port, exc)
            return
        if self._unopened.pop(port, None) is not None:
            logger.info("%s opened at last", port)
        try:
            board_id = await wait_ready(
                stream, deadline=anyio.current_time() + self.probe_deadline, name=port
            )
        except ArduinoIOError as exc:
            with anyio.CancelScope(shield=True):
                await stream.aclose()
            results[port] = self._remember(ProbeResult(port, error=str(exc)))
            return
        self._rekey()
        holder = self._claims.get(board_id)
        if holder is not None:
            # Claimed without an await since the check: concurrent probes cannot both win.
            with anyio.CancelScope(shield=True):
                await stream.aclose()
            self._duplicates.setdefault(board_id, set()).update({holder, port})
            results[port] = self._remember(
                ProbeResult(port, board_id, error=f"duplicate of {holder}")
            )
            self._events.emit(ManagerEvent("duplicate", board_id, port, f"also on {holder}"))
            return
        self._claims[board_id] = port
        result = ProbeResult(port, board_id)
        results[port] = self._remember(result, held=True)
        link = Transport(stream, timeout=self.timeout, name=port)
        assert self._task_group is not None
        # start() returns once the board is attached (or failed), so a scan's caller sees it.
        await self._task_group.start(self._supervise, board_id, link, name=f"board {port}")

    def _remember(self, result: ProbeResult, *, held: bool = False) -> ProbeResult:
        self._failed.pop(result.port, None)
        self._known[result.port] = _Known(result, held)
        return result

    async def _supervise(
        self,
        board_id: int,
        link: Transport,
        *,
        task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
    ) -> None:
        """Run one board's link (see :func:`supervise_link`) and keep the books on it."""

        def forget(outcome: LinkOutcome) -> None:
            self._known.pop(link.name, None)
            self._rekey()
            board = outcome.board
            for key in {board_id, board.board_id if board is not None else board_id}:
                if self._claims.get(key) == link.name:
                    del self._claims[key]
            for ports in self._duplicates.values():
                ports.discard(link.name)
            self._duplicates = {
                bid: ports for bid, ports in self._duplicates.items() if len(ports) > 1
            }
            if outcome.rekeyed and self._task_group is not None:
                # Probed afresh at once: attached under the ID it answers to now.
                self._task_group.start_soon(self.scan)
            if not outcome.started:
                # The port failed mid-handshake or went away: it is forgotten above, so
                # the next scan probes it afresh.
                detail = outcome.detail or "handshake failed"
                self._failed[link.name] = ProbeResult(link.name, board_id, error=detail)
                logger.warning("board 0x%04X on %s not attached: %s", board_id, link.name, detail)
                task_status.started()

        await supervise_link(
            board_id,
            link,
            self._boards,
            self._events,
            on_new=self._choose_modes,
            on_started=task_status.started,
            on_end=forget,
        )
