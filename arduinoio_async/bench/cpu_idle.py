"""Keep the CPUs out of deep idle states while a latency benchmark runs (Linux PM QoS).

Why a benchmark needs it: a round trip through a serial port crosses CPUs several times
(the writer wakes a kernel worker that pushes the tty buffer, which wakes the reader,
often on the other CPU).  A CPU that idles in a halt state takes time to wake: on this
kind of virtual machine the halt exits to the hypervisor and a wake-up costs about 70 us,
on a desktop a deep C-state costs tens to hundreds of microseconds.  At 2 Mbaud that is
more than the whole wire time of a request and its reply, so the idle governor, not the
code under test, decides the result, and it drifts with whatever else keeps the CPUs busy
(the same round trip measured 13 us one hour and 63 us the next here).

The standard cure, used by ``cyclictest`` by default and by real-time robot controllers,
is a PM QoS request: while a process keeps ``/dev/cpu_dma_latency`` open with 0 written
to it, cpuidle only picks idle states with no exit latency (polling).  Idle CPUs then
spin, so hold it only for the measurement.  The device is root-only on most systems; when
it cannot be opened the benchmark says so and runs with the default idle states.

Benchmarks report the condition they ran under (``shallow`` or ``default``) next to the
figures, and can interleave both in one run (:class:`ShallowCpuIdle` is re-entrant per
hold/release), so the idle states' share is measured rather than guessed.
"""

from __future__ import annotations

import argparse
import logging
import os
import struct
from pathlib import Path
from types import TracebackType

logger = logging.getLogger(__name__)

#: The PM QoS interface for the CPU's wake-up latency (Documentation/power/pm_qos_interface).
CPU_DMA_LATENCY = Path("/dev/cpu_dma_latency")

#: Condition names as benchmarks record them; ``both`` (an option value) interleaves them.
DEFAULT = "default"
SHALLOW = "shallow"
BOTH = "both"


class ShallowCpuIdle:
    """A PM QoS request for 0 us CPU wake-up latency, held between :meth:`hold` and
    :meth:`release` (or for a ``with`` block).

    The kernel drops the request when the file is closed, also when the process dies, so
    a crashed benchmark cannot leave the CPUs spinning.
    """

    def __init__(self, path: Path | None = None) -> None:
        self._path = path or CPU_DMA_LATENCY
        self._fd: int | None = None
        self.unavailable: str | None = None  # why hold() could not, once it failed

    @property
    def held(self) -> bool:
        return self._fd is not None

    def hold(self) -> bool:
        """Ask for shallow idle states; False (and :attr:`unavailable` says why) if the
        system does not let this process."""
        if self._fd is not None:
            return True
        fd = None
        try:
            fd = os.open(self._path, os.O_WRONLY)
            os.write(fd, struct.pack("i", 0))
        except OSError as exc:
            if fd is not None:
                os.close(fd)
            self.unavailable = f"{self._path}: {exc.strerror or exc}"
            logger.info("cannot hold the CPUs in shallow idle states: %s", self.unavailable)
            return False
        self._fd = fd
        return True

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> ShallowCpuIdle:
        self.hold()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()

    def set(self, condition: str) -> str:
        """Switch to ``condition`` (:data:`SHALLOW` or :data:`DEFAULT`); returns the
        condition in force (``default`` when shallow was asked for but not possible)."""
        if condition == SHALLOW and self.hold():
            return SHALLOW
        self.release()
        return DEFAULT


def add_option(parser: argparse.ArgumentParser, *, interleave: bool = False) -> None:
    """The benchmarks' ``--cpu-idle`` option (``both`` only where runs interleave)."""
    parser.add_argument(
        "--cpu-idle",
        choices=[DEFAULT, SHALLOW, BOTH] if interleave else [DEFAULT, SHALLOW],
        default=DEFAULT,
        help="CPU idle states while measuring: as configured, held shallow (PM QoS; root)"
        + (", or both interleaved" if interleave else ""),
    )


def conditions(parser: argparse.ArgumentParser, choice: str) -> tuple[ShallowCpuIdle, list[str]]:
    """The conditions a ``--cpu-idle`` choice measures under, and the hold that switches
    between them (released).  Shallow states this system does not grant end the program
    as a usage error (``parser.error``) before anything is measured, so default-idle
    figures are never recorded as shallow ones."""
    wanted = [DEFAULT, SHALLOW] if choice == BOTH else [choice]
    idle = ShallowCpuIdle()
    if SHALLOW in wanted and not idle.hold():
        parser.error(f"--cpu-idle {choice}: {idle.unavailable}")
    idle.release()
    return idle, wanted
