"""A board node's inputs: pins, counters and I2C/sonar sensors published as topics.

Digital inputs publish ``std_msgs/Bool`` at start and on every change the board reports
(from the link's reader, as each frame is decoded); analog inputs ``Float32`` volts or a
``sensor_msgs/BatteryState`` every ``period``; counters ``Int64``; an MPU-6050 on I2C
``sensor_msgs/Imu``; an HC-SR04 ``sensor_msgs/Range``.  Inputs from the board's
firmware-timed stream are :mod:`._stream`'s; this module also holds what both share
(counting publications, waiting out a lost link).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import anyio

from ..board.imu import MPU6050
from ..errors import ArduinoIOError
from ..protocol import I2CSpeed
from . import _messages as msgs
from ._clock import BoardClock
from ._config import BoardConfig, InputConfig
from ._endpoints import Node, Publisher
from ._sources import INPUTS, PulseReading, RangeReading, pulse_payload, range_payload

if TYPE_CHECKING:
    from ..board import Board
    from ..protocol.pins import AnalogPin, CounterPin, DigitalPin

__all__ = ["RECONNECT_POLL", "Inputs"]

log = logging.getLogger(__name__)

#: Seconds between looks at a board whose link failed (a Board has no event for its return).
RECONNECT_POLL = 0.25


class Inputs:
    """The input half of :class:`~._bridge.BoardNode` (a mixin: the node owns the state)."""

    config: BoardConfig
    board: Board
    node: Node
    clock: BoardClock
    published: int
    on_change: Callable[[str, int, int, int], None] | None
    #: The rc inputs' topics whose signal is lost now (the diagnostics list them).
    rc_lost: set[str]

    def _publisher(self, source: InputConfig) -> Publisher:
        return self.node.publisher(source.topic, INPUTS[source.kind].ros_type)

    def _put(self, publisher: Publisher, payload: bytes) -> None:
        publisher.publish(payload)
        self.published += 1

    async def _publish_input(
        self,
        source: InputConfig,
        *,
        task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
    ) -> None:
        publisher = self._publisher(source)
        if source.kind == "bool":
            pin = await self.board.digital_input(
                cast("DigitalPin", source.pin), pull_up=source.pull_up
            )
            started = False
            while True:  # again after the link failed and the board came back
                # Each change is published from the link's reader as its frame is decoded
                # (no hop through a queue and another task: benchmarks/ros2_latency.py);
                # those before the first reading's message wait for it, in order.
                held: list[Any] | None = []

                def on_change(change: Any) -> None:
                    if held is not None:  # noqa: B023 (this round's list: the watch is too)
                        held.append(change)  # noqa: B023
                    else:
                        self._publish_change(source.topic, publisher, change)

                try:
                    async with pin.watch(callback=on_change) as changes:
                        self._put(publisher, msgs.bool_msg(bool(await pin.read())))
                        waiting, held = held, None
                        for change in waiting or ():
                            self._publish_change(source.topic, publisher, change)
                        if not started:
                            started = True
                            task_status.started()
                        async for _ in changes:  # nothing comes: ends with the watch
                            pass
                except ArduinoIOError as exc:
                    if not started:
                        raise  # at start: the bridge does not come up, with this error
                    await self._link_lost(source.topic, exc)

        if source.kind == "imu":
            await self._publish_imu(source, publisher, task_status)
            return
        if source.kind == "sonar":
            await self._publish_sonar(source, publisher, task_status)
            return
        if source.kind == "rc":
            await self._publish_rc(source, publisher, task_status)
            return
        if source.kind == "counter":
            counter = await self.board.counter(cast("CounterPin", source.pin))
            task_status.started()
            while True:
                try:
                    self._put(publisher, msgs.int64_msg(await counter.read()))
                except ArduinoIOError as exc:
                    await self._read_failed(source.topic, exc)
                await anyio.sleep(source.period)
        analog = self.board.analog(cast("AnalogPin", source.pin))
        started = False
        while True:
            try:
                volts = await analog.read_volts() * source.scale
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                if source.kind == "volts":
                    payload = msgs.float32_msg(volts)
                else:
                    now = msgs.Stamp(time.time_ns())
                    payload = msgs.battery_state(now, self.config.frame_id, volts)
                self._put(publisher, payload)
            if not started:
                started = True
                task_status.started()
            await anyio.sleep(source.period)

    def _publish_change(self, topic: str, publisher: Publisher, change: Any) -> None:
        host_ns = time.time_ns() - int((time.monotonic() - change.host_time) * 1e9)
        board_us = self.clock.observe(change.board_time_us, host_ns)
        self._put(publisher, msgs.bool_msg(change.level))
        if self.on_change is not None:
            stamp_ns = self.clock.to_host_ns(board_us)
            self.on_change(topic, publisher.sequence, stamp_ns, host_ns)

    async def _read_failed(self, what: str, exc: ArduinoIOError) -> None:
        """A periodic read failed: once per lost link (then wait for the board), else once
        per failure."""
        if self.board.connected:
            log.warning("%s: %s: %s", self.config.name, what, exc)
        else:
            await self._link_lost(what, exc)

    async def _link_lost(self, what: str, exc: ArduinoIOError) -> None:
        """A watch or stream ended with the link (unplugged, reset): wait until the board is
        connected again (the BoardManager re-adopts it and restores its pins)."""
        log.warning("%s: %s: %s; again once the board is back", self.config.name, what, exc)
        await anyio.sleep(RECONNECT_POLL)
        while not self.board.connected:  # noqa: ASYNC110 (a Board has no event for it)
            await anyio.sleep(RECONNECT_POLL)

    async def _publish_imu(
        self, source: InputConfig, publisher: Publisher, task_status: anyio.abc.TaskStatus[None]
    ) -> None:
        """An MPU-6050 polled every ``period`` (a board without ``stream_ms``), stamped with
        the middle of each read; the helper sets the entry's ranges and scales by them."""
        imu = MPU6050(await self.board.i2c(I2CSpeed.KHZ_400), source.address)
        await imu.configure(accel_g=cast(Any, source.accel_g), gyro_dps=cast(Any, source.gyro_dps))
        task_status.started()
        while True:
            sent = time.time_ns()
            try:
                reading = await imu.read()
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                stamp = msgs.Stamp((sent + time.time_ns()) // 2)
                payload = msgs.imu(stamp, self.config.frame_id, reading.gyro, reading.accel)
                self._put(publisher, payload)
            await anyio.sleep(source.period)

    async def _publish_sonar(
        self, source: InputConfig, publisher: Publisher, task_status: anyio.abc.TaskStatus[None]
    ) -> None:
        """An HC-SR04 fired by the board, its latest reading published every ``period`` as
        a Range (no echo: +inf), stamped when it was measured; none before the first."""
        assert source.echo is not None
        sonar = await self.board.sonar(cast("DigitalPin", source.pin), source.echo)
        task_status.started()
        while True:
            try:
                reading = await sonar.read()
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                if reading.distance_mm is not None or reading.no_echo:
                    metres = None if reading.distance_mm is None else reading.distance_mm / 1000
                    stamp = msgs.Stamp(time.time_ns() - reading.age_ms * 1_000_000)
                    payload = range_payload(stamp, self.config.frame_id, RangeReading(metres))
                    self._put(publisher, payload)
            await anyio.sleep(source.period)

    async def _publish_rc(
        self, source: InputConfig, publisher: Publisher, task_status: anyio.abc.TaskStatus[None]
    ) -> None:
        """An RC receiver channel timed by the board, its last width published every
        ``period`` as -1..1 (:func:`pulse_payload`); NaN while the board reports the signal
        lost (no pulse for ``timeout_ms``) or before the first pulse, never a stale width."""
        ends = {key: source.rc[key] for key in ("low_us", "centre_us", "high_us")}
        rc = await self.board.pulse_input(
            cast("DigitalPin", source.pin), timeout_ms=source.rc["timeout_ms"], **ends
        )
        task_status.started()
        while True:
            try:
                state = await rc.read()
            except ArduinoIOError as exc:
                await self._read_failed(source.topic, exc)
            else:
                width = None if state.lost or not state.width_us else state.width_us
                if width is None:
                    self.rc_lost.add(source.topic)
                else:
                    self.rc_lost.discard(source.topic)
                reading = PulseReading(width, ends["low_us"], ends["centre_us"], ends["high_us"])
                self._put(publisher, pulse_payload(reading))
            await anyio.sleep(source.period)
