r"""Transport layer: byte streams to boards and the request/response engine.

Any anyio ``ByteStream`` carries the protocol: :func:`open_serial_stream` for device paths
and pyserial URLs (``/dev/ttyACM0``, ``socket://host:port``, ``rfc2217://...``), a
pseudo-terminal of the virtual Uno, or :func:`memory_link` in tests.  A stream that can
push received bytes, write without suspending, collect writes or take writes from another
thread declares it by inheriting the interfaces of :mod:`._streams` (:class:`PushStream`,
:class:`ImmediateSender`, :class:`CollectedWrites`, :class:`ThreadSafeSender`,
:class:`RelayingStream`); its port's name and baud rate are :class:`LinkAttribute`\ s.
"""

from ._backend import backend_options, run
from ._bridges import BRIDGES, Bridge, BridgeKind, bridge_for_ids
from ._latency import LinkTuning, last_tuning, port_bridge, tune_link
from ._link import (
    DEFAULT_TIMEOUT,
    FRAMING_ENV,
    QUIET_TIME,
    LinkState,
    LinkStats,
    TraceHook,
    TraceRecord,
    Transport,
    board_error,
    default_framing,
)
from ._memory import MemoryByteStream, memory_link
from ._serial import SerialByteStream, open_serial_stream
from ._streams import (
    Abilities,
    CollectedWrites,
    ImmediateSender,
    LinkAttribute,
    PushStream,
    RelayingStream,
    ThreadSafeSender,
    abilities_of,
)
from ._usb import TICK_HOLDING_BRIDGES, tick_holding_bridge

__all__ = [
    "BRIDGES",
    "DEFAULT_TIMEOUT",
    "FRAMING_ENV",
    "QUIET_TIME",
    "TICK_HOLDING_BRIDGES",
    "Abilities",
    "Bridge",
    "BridgeKind",
    "CollectedWrites",
    "ImmediateSender",
    "LinkAttribute",
    "LinkState",
    "LinkStats",
    "LinkTuning",
    "MemoryByteStream",
    "PushStream",
    "RelayingStream",
    "SerialByteStream",
    "ThreadSafeSender",
    "TraceHook",
    "TraceRecord",
    "Transport",
    "abilities_of",
    "backend_options",
    "board_error",
    "bridge_for_ids",
    "default_framing",
    "last_tuning",
    "memory_link",
    "open_serial_stream",
    "port_bridge",
    "run",
    "tick_holding_bridge",
    "tune_link",
]
