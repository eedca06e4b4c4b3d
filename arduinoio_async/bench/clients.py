"""The reference clients: one Read ID round trip at a time, three ways.

What a round trip costs the host only means something next to what any client must pay
on the same port and the same moment, so every comparison (``arduinoio bench --host``,
``benchmarks/fast_link.py``) runs these three on one port in interleaved rounds:

- :func:`bare_round`: blocking pyserial ``write`` + ``read``: the floor any Python
  client pays (no event loop);
- :func:`minimal_round`: the event loop's own floor: ``os.write``, then a reader
  callback resolves one future per round trip (no library);
- :func:`library_round`: this library, ``await board.read_id()`` (what an application
  calls) or the transport's ``request`` alone.

Each opens the port afresh (exclusively), makes ``warmup`` untimed round trips, then
``samples`` timed ones, and returns the round trip times and the measuring thread's CPU
time per round trip (``time.thread_time``: a responder process, a watchdog thread and
idle waiting do not count).  ``bare_round`` blocks: call it from a worker thread when an
event loop must keep running.
"""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Literal

import anyio
import serial

from .. import protocol as p
from ..board import Board
from ..transport import Transport, open_serial_stream

__all__ = ["CLIENTS", "Round", "bare_round", "library_round", "minimal_round"]

Layer = Literal["board", "link"]
_REQUEST = p.ReadId().encode()
_REPLY_SIZE = len(p.ReadIdReply(0).encode())


@dataclass(frozen=True)
class Round:
    """One client's round on one port."""

    rtts_us: list[float]
    #: CPU time of the measuring thread per timed round trip, microseconds.
    cpu_us: float


def _cpu_per_trip(cpu_start: float, samples: int) -> float:
    return (time.thread_time() - cpu_start) / max(samples, 1) * 1e6


def bare_round(port_path: str, baud: int, samples: int, warmup: int) -> Round:
    """Blocking pyserial round trips (blocks: run it in a worker thread from async code)."""
    port = serial.Serial(port_path, baud, timeout=1.0, exclusive=True)
    try:

        def trip() -> None:
            port.write(_REQUEST)
            if len(port.read(_REPLY_SIZE)) != _REPLY_SIZE:
                raise RuntimeError(f"{port_path}: no reply to READ ID")

        for _ in range(warmup):
            trip()
        rtts = []
        cpu = time.thread_time()
        for _ in range(samples):
            start = time.perf_counter_ns()
            trip()
            rtts.append((time.perf_counter_ns() - start) / 1e3)
        return Round(rtts, _cpu_per_trip(cpu, samples))
    finally:
        port.close()


async def minimal_round(port_path: str, baud: int, samples: int, warmup: int) -> Round:
    """The event loop's floor: ``os.write``, then a reader callback resolves a future."""
    loop = asyncio.get_running_loop()
    port = serial.Serial(port_path, baud, timeout=0, exclusive=True)
    fd = port.fd
    waiting: list[asyncio.Future[None]] = []
    received = [0]

    def readable() -> None:
        received[0] += len(os.read(fd, 256))
        if received[0] >= _REPLY_SIZE and waiting:
            received[0] -= _REPLY_SIZE
            waiting.pop().set_result(None)

    async def trip() -> None:
        future = loop.create_future()
        waiting.append(future)
        os.write(fd, _REQUEST)
        await future

    loop.add_reader(fd, readable)
    try:
        with anyio.fail_after(10 + (warmup + samples) / 1000):  # one scope: no cost per trip
            return await _timed(trip, samples, warmup)
    finally:
        loop.remove_reader(fd)
        port.close()


async def library_round(
    port_path: str, baud: int, samples: int, warmup: int, *, through: Layer = "board"
) -> Round:
    """This library's Read ID round trips, ``through`` one of two layers:

    - ``"board"``: ``Board.open`` (handshake untimed), then ``await board.read_id()``:
      what an application calls (``benchmarks.fast_link``'s goal is stated for it);
    - ``"link"``: the :class:`~arduinoio_async.transport.Transport` alone and
      ``link.request(ReadId())``: the library's own round trip without the board layer
      (``arduinoio bench --host`` compares this with the bare loop; the board layer adds
      about 15 % of CPU per round trip on top, measured 2026-11-26).
    """
    if through == "board":
        async with Board.open(port_path, baudrate=baud) as board:
            return await _timed(board.read_id, samples, warmup)
    stream = await open_serial_stream(port_path, baud)
    async with Transport(stream, name=port_path) as link:
        return await _timed(lambda: link.request(p.ReadId()), samples, warmup)


async def _timed(trip: Callable[[], Awaitable[object]], samples: int, warmup: int) -> Round:
    for _ in range(warmup):
        await trip()
    rtts = []
    cpu = time.thread_time()
    for _ in range(samples):
        start = time.perf_counter_ns()
        await trip()
        rtts.append((time.perf_counter_ns() - start) / 1e3)
    return Round(rtts, _cpu_per_trip(cpu, samples))


async def _bare_in_thread(port_path: str, baud: int, samples: int, warmup: int) -> Round:
    return await anyio.to_thread.run_sync(bare_round, port_path, baud, samples, warmup)


#: The three clients as coroutines (the bare one in a worker thread), by result name.
CLIENTS: dict[str, Callable[[str, int, int, int], Awaitable[Round]]] = {
    "bare_pyserial": _bare_in_thread,
    "minimal_asyncio": minimal_round,
    "library": library_round,
}
