"""Virtual Arduino Uno: the project firmware running unmodified in simavr.

Tests and benchmarks open :attr:`VirtualUno.port` with pyserial exactly like a real
``/dev/ttyACM0``, and steer the simulated circuit (analog voltages, pin drives, pulses,
faults, unplug/replug) through the harness's control socket.  See
``firmware/sim/README.md`` for the harness itself.

* :mod:`.virtual_uno`: :class:`VirtualUno` (launcher and control client) and its results;
* :mod:`.harness`: finding the harness and firmware, and the simulator's errors.
"""

from ._demo import example_arguments, example_board, port_or_virtual_uno
from ._quadrature import QuadratureGenerator
from ._rcpulse import RcPulseSource
from ._sonar import SonarModel, SonarStatus, SonarTrigger
from ._spi_device import SpiDeviceStatus, SpiFrame
from .harness import (
    SimulatorError,
    SimulatorNotAvailable,
    find_firmware_elf,
    find_harness_binary,
    find_test_firmware,
)
from .virtual_uno import (
    CircuitPin,
    FirmwareCycles,
    Fixture,
    PulseStats,
    UsbBridge,
    VirtualUno,
    start_virtual_unos,
)

__all__ = [
    "CircuitPin",
    "FirmwareCycles",
    "Fixture",
    "PulseStats",
    "QuadratureGenerator",
    "RcPulseSource",
    "SimulatorError",
    "SimulatorNotAvailable",
    "SonarModel",
    "SonarStatus",
    "SonarTrigger",
    "SpiDeviceStatus",
    "SpiFrame",
    "UsbBridge",
    "VirtualUno",
    "example_arguments",
    "example_board",
    "find_firmware_elf",
    "find_harness_binary",
    "find_test_firmware",
    "port_or_virtual_uno",
    "start_virtual_unos",
]
