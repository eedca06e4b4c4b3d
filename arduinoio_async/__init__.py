"""arduinoio_async: Arduino Unos as typed, asyncio-driven I/O boards for robots.

``from arduinoio_async import Board, BoardManager, D2`` is the whole import a robot program
needs.  The board, manager, handle, stream, simulator and fake-board names are imported
on first use (module ``__getattr__``), so ``import arduinoio_async`` stays cheap for tools
that only want the pin names or the error classes, and no import cycle can form.
"""

from __future__ import annotations

import importlib
import logging
from contextlib import AbstractAsyncContextManager
from typing import TYPE_CHECKING, Any

from . import _schemes, errors, protocol
from ._version import __version__
from .errors import (
    ArduinoIOError,
    BoardDisconnectedError,
    BoardError,
    BoardNotFoundError,
    BoardTimeoutError,
    DuplicateBoardError,
    FailsafeTrippedError,
    I2CError,
    LinkCapacityError,
    LinkError,
    LinkResyncError,
    PinCapabilityError,
    PinRoleError,
    PortBusyError,
    ProtocolError,
    ReplyMismatchError,
    StaleHandleError,
    TimerBusyError,
    UsageError,
    ValueRangeError,
    WatchLostError,
)
from .protocol.pins import (
    A0,
    A1,
    A2,
    A3,
    A4,
    A5,
    D2,
    D3,
    D4,
    D5,
    D6,
    D7,
    D8,
    D9,
    D10,
    D11,
    D12,
    D13,
    AnalogPin,
    DigitalPin,
)

# A library logs and never prints: without this, Python's last-resort handler writes the
# library's warnings to stderr when the application configured no logging.  The
# application's handlers (``logging.basicConfig`` and the like) still see every record.
logging.getLogger(__name__).addHandler(logging.NullHandler())


def _open_remote(address: str, **options: Any) -> AbstractAsyncContextManager[Any]:
    """``Board.open("zenoh://...")``: the board layer hands the network's addresses to the
    one opener, which sits above it (imported here, on first use, to keep this cheap)."""
    from .opener import open_board

    return open_board(address, **options)


for _scheme in ("zenoh",):  # opener.REMOTE_SCHEMES, without importing it
    _schemes.register(_scheme, _open_remote)

if TYPE_CHECKING:
    from .board import Board, FailsafeConfig
    from .board.handles import (
        AnalogInput,
        Counter,
        DigitalInput,
        DigitalOutput,
        Gpio,
        I2CBus,
        PinState,
        PulseOutput,
        Servo,
        SoftPwm,
    )
    from .board.i2c_blocks import I2CBlock
    from .board.imu import MPU6050, ImuReading
    from .board.motors import DutyPwm, Motor
    from .board.steppers import LimitSwitch, Stepper, StepperState
    from .board.streaming import Sample, SampleStream
    from .manager import BoardManager, ManagerEvent, ProbeResult
    from .opener import open_board
    from .protocol import I2CSpeed
    from .sim import VirtualUno
    from .testing import FakeBoard

#: Public name -> the module that defines it, imported on first access.
_LAZY = {
    "Board": ".board",
    "FailsafeConfig": ".board",
    "AnalogInput": ".board.handles",
    "Counter": ".board.handles",
    "DigitalInput": ".board.handles",
    "DigitalOutput": ".board.handles",
    "Gpio": ".board.handles",
    "I2CBus": ".board.handles",
    "I2CBlock": ".board.i2c_blocks",
    "MPU6050": ".board.imu",
    "ImuReading": ".board.imu",
    "PinState": ".board.handles",
    "PulseOutput": ".board.handles",
    "Servo": ".board.handles",
    "SoftPwm": ".board.handles",
    "BoardManager": ".manager",
    "DutyPwm": ".board.motors",
    "Motor": ".board.motors",
    "Stepper": ".board.steppers",
    "StepperState": ".board.steppers",
    "LimitSwitch": ".board.steppers",
    "ManagerEvent": ".manager",
    "ProbeResult": ".manager",
    "open_board": ".opener",
    "I2CSpeed": ".protocol",
    "VirtualUno": ".sim",
    "Sample": ".board.streaming",
    "SampleStream": ".board.streaming",
    "FakeBoard": ".testing",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = [
    "A0",
    "A1",
    "A2",
    "A3",
    "A4",
    "A5",
    "D2",
    "D3",
    "D4",
    "D5",
    "D6",
    "D7",
    "D8",
    "D9",
    "D10",
    "D11",
    "D12",
    "D13",
    "MPU6050",
    "AnalogInput",
    "AnalogPin",
    "ArduinoIOError",
    "Board",
    "BoardDisconnectedError",
    "BoardError",
    "BoardManager",
    "BoardNotFoundError",
    "BoardTimeoutError",
    "Counter",
    "DigitalInput",
    "DigitalOutput",
    "DigitalPin",
    "DuplicateBoardError",
    "DutyPwm",
    "FailsafeConfig",
    "FailsafeTrippedError",
    "FakeBoard",
    "Gpio",
    "I2CBlock",
    "I2CBus",
    "I2CError",
    "I2CSpeed",
    "ImuReading",
    "LimitSwitch",
    "LinkCapacityError",
    "LinkError",
    "LinkResyncError",
    "ManagerEvent",
    "Motor",
    "PinCapabilityError",
    "PinRoleError",
    "PinState",
    "PortBusyError",
    "ProbeResult",
    "ProtocolError",
    "PulseOutput",
    "ReplyMismatchError",
    "Sample",
    "SampleStream",
    "Servo",
    "SoftPwm",
    "StaleHandleError",
    "Stepper",
    "StepperState",
    "TimerBusyError",
    "UsageError",
    "ValueRangeError",
    "VirtualUno",
    "WatchLostError",
    "__version__",
    "errors",
    "open_board",
    "protocol",
]
