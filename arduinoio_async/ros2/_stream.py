"""A board's firmware-timed stream as ROS messages, each stamped with the board's time.

One stream per board carries every streamed input (the board runs one): analog inputs
(``Float32`` volts or ``BatteryState``) and MPU-6050 IMUs (``sensor_msgs/Imu``, one
14-byte I2C register block each, read by the board every period) when the board has
``stream_ms``, and encoders (``sensor_msgs/JointState``) always.  Each sample's board
time goes through the node's
:class:`~._clock.BoardClock` into ``header.stamp``, so a stamp says when the board
sampled, not when the host got round to it.

An IMU publishes one message per sample, in m/s^2 and rad/s at the ranges its entry
sets (:class:`~arduinoio_async.board.imu.MPU6050` scales them); a sample whose block
read failed (the device NACKed) publishes nothing for that IMU, and the board counts it.

An encoder publishes when its count changed since its last message, and at least every
``period`` seconds of board time while it stands still (velocity 0 then).  Its velocity
is the counts moved since its last message over the board's time between the two
samples: a count that changes every sample gives the rate exactly; a slower one gives
the mean since the previous count.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import anyio

from ..board.imu import MPU6050
from ..errors import ArduinoIOError
from ..protocol import VCC_MV, I2CSpeed
from . import _messages as msgs
from ._clock import BoardClock
from ._config import InputConfig
from ._endpoints import Publisher
from ._sources import EncoderSample, joint_reading

if TYPE_CHECKING:
    from ..board import Board
    from ..protocol.pins import AnalogPin, DigitalPin

__all__ = ["DEFAULT_STREAM_MS", "StreamedInputs", "streamed"]

log = logging.getLogger(__name__)

#: Volts of one ADC count (AVCC 5 V over 1024 steps, as ``AnalogInput.read_volts``).
VOLTS_PER_COUNT = VCC_MV / 1000 / 1024
#: The stream's period when a board streams only for its encoders (no ``stream_ms``).
DEFAULT_STREAM_MS = 10.0


def streamed(inputs: Sequence[InputConfig], stream_ms: float | None) -> list[InputConfig]:
    """The inputs that come from the stream: encoders always, analog inputs and IMUs with
    stream_ms (without it an IMU is polled over I2C every ``period``)."""
    analog = ("volts", "battery", "imu") if stream_ms is not None else ()
    return [s for s in inputs if s.kind == "encoder" or s.kind in analog]


@dataclass
class _Joint:
    source: InputConfig
    publisher: Publisher
    slot: int
    last: EncoderSample | None = None


class StreamedInputs:
    """The streamed inputs of one board: set up, then publish every sample."""

    def __init__(
        self,
        board: Board,
        sources: Sequence[InputConfig],
        *,
        period_ms: float | None,
        clock: BoardClock,
        frame_id: str,
        publisher: Callable[[InputConfig], Publisher],
        put: Callable[[Publisher, bytes], None],
        link_lost: Callable[[str, ArduinoIOError], Awaitable[None]],
    ) -> None:
        self.board = board
        self.period_ms = DEFAULT_STREAM_MS if period_ms is None else period_ms
        self.clock = clock
        self.frame_id = frame_id
        self._put = put
        self._link_lost = link_lost
        self.analog = [(s, publisher(s)) for s in sources if s.kind in ("volts", "battery")]
        self._encoders = [(s, publisher(s)) for s in sources if s.kind == "encoder"]
        self._imu_sources = [(s, publisher(s)) for s in sources if s.kind == "imu"]
        self.joints: list[_Joint] = []
        #: Each IMU's helper (its ranges scale the block) and publisher, in block order.
        self.imus: list[tuple[MPU6050, Publisher]] = []

    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Set up the encoders, then stream until cancelled (again after a lost link)."""
        for source, publisher in self._encoders:
            assert source.pin_b is not None
            handle = await self.board.encoder(
                cast("DigitalPin", source.pin), source.pin_b, mode=cast(Any, source.mode)
            )
            self.joints.append(_Joint(source, publisher, handle.slot))
        if self._imu_sources:
            bus = await self.board.i2c(I2CSpeed.KHZ_400)
            for source, publisher in self._imu_sources:
                imu = MPU6050(bus, source.address)
                await imu.configure(accel_g=cast(Any, source.accel_g),
                                    gyro_dps=cast(Any, source.gyro_dps))  # fmt: skip
                self.imus.append((imu, publisher))
        blocks = [imu.block for imu, _ in self.imus]
        pins = [cast("AnalogPin", source.pin) for source, _ in self.analog]
        started = False
        while True:
            try:
                async with self.board.stream(
                    analog=pins,
                    encoders=bool(self.joints),
                    i2c=blocks,
                    period_ms=self.period_ms,
                ) as samples:
                    if not started:
                        started = True
                        task_status.started()
                    async for sample in samples:
                        self.publish(sample)
            except ArduinoIOError as exc:
                if not started:
                    raise
                for joint in self.joints:  # the board's count may have restarted
                    joint.last = None
                await self._link_lost("stream", exc)

    def publish(self, sample: Any) -> None:
        """One stream sample: every analog input, and each encoder that moved or is due."""
        host_ns = time.time_ns() - int((time.monotonic() - sample.host_time) * 1e9)
        board_us = self.clock.observe(sample.board_time_us, host_ns)
        stamp = msgs.Stamp(self.clock.to_host_ns(board_us))
        for source, publisher in self.analog:
            volts = sample.analog[cast("AnalogPin", source.pin)] * VOLTS_PER_COUNT * source.scale
            if source.kind == "volts":
                payload = msgs.float32_msg(volts)
            else:
                payload = msgs.battery_state(stamp, self.frame_id, volts)
            self._put(publisher, payload)
        for index, (imu, publisher) in enumerate(self.imus):
            data = sample.i2c[index]
            if data is None:  # the read failed on the board (counted there)
                continue
            motion = imu.decode(data)
            self._put(publisher, msgs.imu(stamp, self.frame_id, motion.gyro, motion.accel))
        for joint in self.joints:
            now = EncoderSample(sample.encoders[joint.slot], sample.board_time_us)
            last = joint.last
            if last is not None and now.count == last.count:
                idle_us = (now.board_time_us - last.board_time_us) & 0xFFFFFFFF
                if idle_us < joint.source.period * 1e6:
                    continue
            reading = joint_reading(now, last, joint.source.counts_per_rev)
            joint.last = now
            payload = msgs.joint_state(
                stamp,
                [joint.source.joint],
                [reading.position],
                [reading.velocity],
                self.frame_id,
            )
            self._put(joint.publisher, payload)
