"""Launcher and control client for the virtual Uno harness (``virtual-uno``).

The harness is a separate C process because simavr is a C library that is not thread safe
and must be paced against the wall clock in a tight loop; Python only starts it, reads the
one JSON line it prints when ready, and talks to its JSON-lines control socket.  Tests open
:attr:`VirtualUno.port` as a real Uno's; :mod:`.harness` finds the binary and firmware.
"""

from __future__ import annotations

import json
import os
import signal
import tempfile
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager, suppress
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Literal, cast

import anyio
import anyio.abc
import anyio.to_thread
from anyio.streams.buffered import BufferedByteReceiveStream

from ..protocol import DEFAULT_BAUD
from ..protocol.profiles import DEFAULT_PROFILE
from ._quadrature import QuadratureMethods
from ._rcpulse import RcPulseMethods
from ._readings import CircuitPin, FirmwareCycles, PulseStats
from ._sonar import SonarModelMethods
from ._spi_device import SpiDeviceMethods
from .harness import (
    INSTALL_HINT,
    SimulatorError,
    SimulatorNotAvailable,
    find_firmware_elf,
    find_harness_binary,
)

__all__ = [
    "CircuitPin",
    "FirmwareCycles",
    "Fixture",
    "PulseStats",
    "UsbBridge",
    "VirtualUno",
    "start_virtual_unos",
]

Fixture = Literal["open", "loopback", "r2r"]
#: The USB bridge model between the simulated UART and the pty (firmware/sim/README.md):
#: none, the Uno's ATmega16U2 (4.096 ms tick), an FTDI FT232R (latency timer, 62-byte
#: packets) or a CH340 (next USB frame).
UsbBridge = Literal["none", "16u2", "ftdi", "ch340"]
_USB_BRIDGES = ("none", "16u2", "ftdi", "ch340")
PinName = int | str


def _pin_arg(pin: PinName) -> PinName:
    """Pins go to the harness as 0..19 or "D9"/"A0"; both are accepted unchanged."""
    return pin


class VirtualUno(QuadratureMethods, SpiDeviceMethods, RcPulseMethods, SonarModelMethods):
    """One simulated Uno: starts the harness process and wraps its control commands.

    Use as ``async with VirtualUno(board_id=1) as uno:`` and open ``uno.port`` with pyserial.
    The process is stopped (SIGTERM, then SIGKILL) when the context exits, also on
    cancellation, so tests never leak simulator processes.  ``board="mega2560"``: an
    ATmega2560 running the Mega image (jumpers D2-D15, ADC0-15; no R2R ladders yet).
    """

    def __init__(
        self,
        *,
        board_id: int | None = None,
        fixture: Fixture = "open",
        baud: int = DEFAULT_BAUD,
        fast: bool = False,
        reset_on_open: bool = False,
        boot_delay_ms: int | None = None,
        usb_bridge: UsbBridge = "none",
        ftdi_latency_ms: int | None = None,
        fault_drop: float = 0.0,
        fault_insert: float = 0.0,
        fault_flip: float = 0.0,
        seed: int | None = None,
        r2r_tolerance: float | None = None,
        elf: str | os.PathLike[str] | None = None,
        profile: str = DEFAULT_PROFILE,
        bootloader: str | os.PathLike[str] | None = None,
        binary: str | os.PathLike[str] | None = None,
        control_path: str | os.PathLike[str] | None = None,
        start_timeout: float = 10.0,
        board: str = "uno",
    ) -> None:
        if board_id is not None and not 0 <= board_id <= 0xFFFF:
            raise ValueError(f"board_id must be 0..65535, got {board_id}")
        if board not in ("uno", "mega2560"):
            raise ValueError(f"unknown board {board!r} (uno or mega2560)")
        if fixture not in ("open", "loopback", "r2r"):
            raise ValueError(f"unknown fixture {fixture!r}")
        if usb_bridge not in _USB_BRIDGES:
            raise ValueError(f"unknown usb_bridge {usb_bridge!r}")
        if ftdi_latency_ms is not None and (
            usb_bridge != "ftdi" or not 1 <= ftdi_latency_ms <= 255
        ):
            raise ValueError("ftdi_latency_ms needs usb_bridge='ftdi' and 1..255 ms")
        self.board_id = board_id
        self.fixture: Fixture = fixture
        self.baud = baud
        self.fast = fast
        self.reset_on_open = reset_on_open
        self.boot_delay_ms = boot_delay_ms
        self.usb_bridge: UsbBridge = usb_bridge
        self.ftdi_latency_ms = ftdi_latency_ms
        self.fault_drop = fault_drop
        self.fault_insert = fault_insert
        self.fault_flip = fault_flip
        self.seed = seed
        self.r2r_tolerance = r2r_tolerance
        self._elf = Path(elf) if elf is not None else None
        #: The build profile run when no ``elf`` is given (protocol/profiles.py).
        self.profile = profile
        self.bootloader = Path(bootloader) if bootloader is not None else None
        self._binary = Path(binary) if binary is not None else None
        self._control_request = Path(control_path) if control_path is not None else None
        self.start_timeout = start_timeout
        self.board = board  #: the harness's MCU: uno or mega2560
        self.port: str = ""
        self.control_path: str = ""
        self.pid: int | None = None
        self._process: anyio.abc.Process | None = None
        self._stderr: IO[bytes] | None = None
        self._stream: anyio.abc.SocketStream | None = None
        self._reader: BufferedByteReceiveStream | None = None
        self._lock = anyio.Lock()

    # ------------------------------------------------------------------ lifecycle
    def command_line(self) -> list[str]:
        """The exact harness command line, resolved now (raises SimulatorNotAvailable).

        Blocking: the first call may build the harness into the user cache.  With
        ``bootloader`` the board starts with only that bootloader in its boot section and
        an erased application flash, unless ``elf`` puts an application there too; it
        resets into the bootloader whenever the port is opened (DTR), as a Uno does.
        """
        binary = self._binary or find_harness_binary()
        if not binary.is_file():
            raise SimulatorNotAvailable(
                f"virtual Uno harness not found at {binary}: {INSTALL_HINT}"
            )
        args = [str(binary)]
        if self.bootloader is not None:
            if not self.bootloader.is_file():
                raise SimulatorNotAvailable(f"bootloader image {self.bootloader} does not exist")
            args += ["--bootloader", str(self.bootloader)]
        elf = self._elf
        if elf is None and self.bootloader is None:
            elf = find_firmware_elf(self.baud, self.profile, self.board)
        if elf is not None:
            if not elf.is_file():
                raise SimulatorNotAvailable(f"firmware ELF not found at {elf}: {INSTALL_HINT}")
            args += ["--elf", str(elf)]
        args += ["--baud", str(self.baud), "--fixture", self.fixture]
        args += ["--usb-bridge", self.usb_bridge, "--exit-with-parent", "--board", self.board]
        if self.ftdi_latency_ms is not None:
            args += ["--ftdi-latency-ms", str(self.ftdi_latency_ms)]
        if self.board_id is not None:
            args += ["--id", str(self.board_id)]
        if self.fast:
            args.append("--fast")
        if self.reset_on_open:
            args.append("--reset-on-open")
        if self.boot_delay_ms is not None:
            args += ["--boot-delay-ms", str(self.boot_delay_ms)]
        for flag, value in (
            ("--fault-drop", self.fault_drop),
            ("--fault-insert", self.fault_insert),
            ("--fault-flip", self.fault_flip),
        ):
            if value:
                args += [flag, repr(float(value))]
        if self.seed is not None:
            args += ["--seed", str(self.seed)]
        if self.r2r_tolerance is not None:
            args += ["--r2r-tolerance", repr(float(self.r2r_tolerance))]
        if self._control_request is not None:
            args += ["--control", str(self._control_request)]
        return args

    async def start(self) -> VirtualUno:
        """Start the harness and wait for its ready line; errors name what is missing."""
        if self._process is not None:
            raise SimulatorError("virtual Uno already started")
        args = await anyio.to_thread.run_sync(self.command_line)
        self._stderr = tempfile.TemporaryFile()  # noqa: SIM115 - closed in stop()
        try:
            self._process = await anyio.open_process(
                args, stdin=None, stdout=-1, stderr=self._stderr.fileno()
            )
        except OSError as exc:
            self._close_stderr()
            raise SimulatorNotAvailable(f"cannot run {args[0]}: {exc}; {INSTALL_HINT}") from exc
        try:
            line = await self._read_ready_line()
            info = json.loads(line)
            self.port = str(info["port"])
            self.control_path = str(info["control"])
            self.pid = int(info["pid"])
            await self._connect()
        except BaseException:
            with anyio.CancelScope(shield=True):
                await self.stop()
            raise
        return self

    async def _read_ready_line(self) -> bytes:
        assert self._process is not None and self._process.stdout is not None
        reader = BufferedByteReceiveStream(self._process.stdout)
        try:
            with anyio.fail_after(self.start_timeout):
                return await reader.receive_until(b"\n", 4096)
        except (anyio.EndOfStream, anyio.IncompleteRead, TimeoutError) as exc:
            detail = self._stderr_text()
            if "error while loading shared libraries" in detail:
                raise SimulatorNotAvailable(
                    f"simavr libraries missing: {detail.strip()}; {INSTALL_HINT}"
                ) from exc
            raise SimulatorError(f"virtual Uno did not start: {detail.strip() or exc!r}") from exc

    def _stderr_text(self) -> str:
        if self._stderr is None:
            return ""
        try:
            self._stderr.seek(0)
            return self._stderr.read().decode(errors="replace")[-2000:]
        except (OSError, ValueError):
            return ""

    def _close_stderr(self) -> None:
        if self._stderr is not None:
            self._stderr.close()
            self._stderr = None

    async def _connect(self) -> None:
        self._stream = await anyio.connect_unix(self.control_path)
        self._reader = BufferedByteReceiveStream(self._stream)

    async def stop(self) -> None:
        """Stop the harness: SIGTERM (it removes its socket), SIGKILL after 5 s."""
        if self._stream is not None:
            with anyio.CancelScope(shield=True):
                await self._stream.aclose()
            self._stream = None
            self._reader = None
        process, self._process = self._process, None
        if process is not None:
            with anyio.CancelScope(shield=True):
                if process.returncode is None:
                    _signal(process.pid, signal.SIGTERM)
                    with anyio.move_on_after(5):
                        await process.wait()
                    if process.returncode is None:
                        _signal(process.pid, signal.SIGKILL)
                        await process.wait()
                await process.aclose()
        self._close_stderr()

    @property
    def running(self) -> bool:
        """True while the harness process is alive (it may have crashed)."""
        return self._process is not None and self._process.returncode is None

    async def wait_exited(self) -> int | None:
        """Wait until the harness process exits (e.g. crashed); returns its exit code."""
        process = self._process
        if process is None:
            return None
        return await process.wait()

    async def __aenter__(self) -> VirtualUno:
        return await self.start()

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()

    # ------------------------------------------------------------------ control channel
    async def command(self, cmd: str, **params: Any) -> dict[str, Any]:
        """Send one control request and return its reply; ``ok: false`` raises SimulatorError."""
        if self._stream is None or self._reader is None:
            raise SimulatorError("virtual Uno is not running")
        request = json.dumps({"cmd": cmd, **params}).encode() + b"\n"
        async with self._lock:
            try:
                await self._stream.send(request)
                line = await self._reader.receive_until(b"\n", 1 << 20)
            except (
                anyio.EndOfStream,
                anyio.IncompleteRead,
                anyio.BrokenResourceError,
                OSError,
            ) as exc:
                raise SimulatorError(
                    f"control channel closed: {self._stderr_text().strip() or exc!r}"
                ) from exc
        reply = cast(dict[str, Any], json.loads(line))
        if not reply.get("ok"):
            raise SimulatorError(f"{cmd}: {reply.get('error', 'failed')}")
        return reply

    async def status(self) -> dict[str, Any]:
        """Cycle count, simulated/wall time, pacing lag, port, plugged state, counters."""
        return await self.command("status")

    async def set_analog(self, channel: int, mv: float) -> None:
        """Voltage on ADC ``channel`` (0..7, Mega 0..15) in mV; an R2R ladder overrides it."""
        await self.command("set_analog", channel=channel, mv=mv)

    async def set_temperature(self, celsius: float) -> None:
        """Set the chip temperature; the sensor reads 314 mV + 1 mV/C * (celsius - 25)."""
        await self.command("set_temperature", celsius=celsius)

    async def drive(self, pin: PinName, level: int | bool | None) -> None:
        """Drive an input pin from outside (0/1), or release it with ``None``."""
        await self.command("drive", pin=_pin_arg(pin), level=None if level is None else int(level))

    async def pin(self, pin: PinName) -> CircuitPin:
        """DDR, PORT and the level the circuit sees on ``pin`` (0..19 or "D9"/"A0")."""
        r = await self.command("pin", pin=_pin_arg(pin))
        return CircuitPin(
            pin=r["pin"], ddr=r["ddr"], port=r["port"], level=r["level"], mv=r.get("mv")
        )

    async def pulses(self, pin: PinName, count: int, high_us: float, low_us: float) -> None:
        """Start ``count`` pulses on D2 or D3 (asynchronous; see :meth:`wait_pulses`)."""
        await self.command("pulses", pin=_pin_arg(pin), count=count, high_us=high_us, low_us=low_us)

    async def wait_pulses(self, timeout: float = 10.0) -> None:
        """Wait until the pulse generator is idle, polling ``status``."""
        with anyio.fail_after(timeout):
            while (await self.status())["pulses_active"]:  # noqa: ASYNC110 - remote state
                await anyio.sleep(0.005)

    async def pulse_stats(self, pin: PinName) -> PulseStats:
        """Recent high times and periods captured on D2..D7, D9 or D10 (any pin works)."""
        r = await self.command("pulse_stats", pin=_pin_arg(pin))
        return PulseStats(
            pin=r["pin"],
            count=r["count"],
            falls=r["falls"],
            level=r["level"],
            high_us=tuple(r["high_us"]),
            period_us=tuple(r["period_us"]),
            highs=int(r.get("highs", 0)),
            periods=int(r.get("periods", 0)),
            rise_us=tuple(r.get("rise_us", ())),
            last_edge_us=r.get("last_edge_us"),
        )

    async def clear_pulse_stats(self, pin: PinName) -> None:
        """Forget captured pulses on ``pin``."""
        await self.command("clear_pulse_stats", pin=_pin_arg(pin))

    async def set_faults(
        self,
        drop: float | None = None,
        insert: float | None = None,
        flip: float | None = None,
        seed: int | None = None,
    ) -> None:
        """Change per-byte fault probabilities on board->host bytes (``None`` keeps a value)."""
        params: dict[str, Any] = {}
        for key, value in (("drop", drop), ("insert", insert), ("flip", flip), ("seed", seed)):
            if value is not None:
                params[key] = value
        await self.command("set_faults", **params)

    async def unplug(self) -> None:
        """Pull the USB cable: the port disappears (host gets I/O errors), the AVR loses power."""
        await self.command("unplug")

    async def replug(self) -> str:
        """Plug back in: fresh boot on a NEW pseudo-terminal, whose path is returned."""
        r = await self.command("replug")
        self.port = str(r["port"])
        return self.port

    async def set_latency_timer(self, ms: int) -> None:
        """Set the FTDI model's latency timer (1..255 ms), as the host's driver sets a real
        chip's when its sysfs ``latency_timer`` is written (``usb_bridge="ftdi"`` only)."""
        await self.command("set_latency_timer", ms=ms)

    async def reset(self) -> None:
        """Power-on reset of the AVR (EEPROM kept)."""
        await self.command("reset")

    async def firmware_cycles(self, clear: bool = False) -> FirmwareCycles:
        """Per-request firmware time in cycles: last request byte read -> first reply byte."""
        r = await self.command("firmware_cycles", **({"clear": True} if clear else {}))
        return FirmwareCycles(samples=tuple(r["samples"]), last=r["last"])

    async def eeprom_i2c(self, offset: int = 0, length: int = 16) -> bytes:
        """Contents of the 256-byte I2C EEPROM (7-bit address 0x50) on the test circuit."""
        r = await self.command("eeprom_i2c", offset=offset, length=length)
        return bytes(r["bytes"])

    async def eeprom(self, offset: int = 0, length: int = 16) -> bytes:
        """Contents of the ATmega328P's own EEPROM (board ID at 0..1)."""
        r = await self.command("eeprom", offset=offset, length=length)
        return bytes(r["bytes"])


@asynccontextmanager
async def start_virtual_unos(
    ids: Sequence[int | None], **options: Any
) -> AsyncIterator[list[VirtualUno]]:
    """Start one virtual Uno per ID concurrently; all are stopped when the context exits.

    If any board fails to start, the ones already running are stopped before the error
    propagates, so a half-started fleet never leaks processes.
    """
    boards = [VirtualUno(board_id=board_id, **options) for board_id in ids]
    for board in boards:  # missing binary/ELF: plain SimulatorNotAvailable, no ExceptionGroup
        await anyio.to_thread.run_sync(board.command_line)
    try:
        async with anyio.create_task_group() as tg:
            for board in boards:
                tg.start_soon(board.start)
        yield boards
    finally:
        with anyio.CancelScope(shield=True):
            for board in boards:
                await board.stop()


def _signal(pid: int, signum: int) -> None:
    """Signal the harness without reaping it.  ``Process.send_signal`` first polls the
    child (``Popen.send_signal`` does), and a harness that had just died -- Ctrl-C reaches
    the whole process group -- was reaped there, behind the back of asyncio's child
    watcher, which then printed "Unknown child process pid ..." under the CLI's one-line
    error.  A child that died stays a zombie until the watcher reaps it (and sets the
    returncode the caller checked), so its pid is not reused meanwhile."""
    with suppress(ProcessLookupError):
        os.kill(pid, signum)
