"""The bridge: each configured board as a ROS 2 node, its pins as topics.

Per board (:class:`BoardNode`): digital inputs publish ``std_msgs/Bool`` at start and on
every change the board reports; analog inputs publish ``std_msgs/Float32`` volts (or a
``sensor_msgs/BatteryState``) every ``period`` or, with ``stream_ms``, every sample of a
firmware-timed stream stamped with the board's clock; counters ``Int64`` and an
MPU-6050 on I2C ``sensor_msgs/Imu``.  Digital outputs take ``Bool``, servos ``Float64``
radians (0 = centre, +-pi/2 = the ends) and motors ``Float64`` speeds -1..1.  An output
with a ``timeout`` goes to its safe state when no command came for that long (the
freshness a ros2_control hardware interface promises) and stays there until the next
command; ``link_failsafe_ms`` arms the board's own watchdog with the same states.  The
diagnostics (``/diagnostics``, ``diagnostic_msgs/DiagnosticArray``) say which outputs
timed out and whether the board is there.  A board that disconnects leaves its node on
the graph; its inputs publish again once the manager has it back.

This module holds the node (what it runs) and its diagnostics; the outputs are
:mod:`._outputs`, the polled and on-change inputs :mod:`._inputs`, the streamed ones
:mod:`._stream`.

Commands are *latest wins*: a command that arrives while the previous write is still on
the wire replaces any command waiting behind it, so a fast publisher never builds a
queue of stale set-points.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import anyio
import zenoh

from ..errors import ArduinoIOError, UsageError
from . import _messages as msgs
from ._clock import BoardClock
from ._config import BoardConfig, BridgeConfig
from ._endpoints import Context, Node
from ._inputs import Inputs
from ._outputs import Outputs, _Command
from ._stream import StreamedInputs, streamed

if TYPE_CHECKING:
    from ..board import Board

__all__ = ["BoardNode", "run_bridge"]

#: Where every node publishes its diagnostics (the ROS convention, an absolute name).
DIAGNOSTICS_TOPIC = "/diagnostics"


async def run_bridge(
    session: zenoh.Session,
    config: BridgeConfig,
    boards: Mapping[int, Board],
    *,
    task_status: anyio.abc.TaskStatus[list[BoardNode]] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve every configured board (``boards``: board ID -> open Board) until cancelled.

    ``task_status.started`` gets the nodes once every node, publisher and subscription
    is declared and each input published its first value.
    """
    missing = [f"0x{b.board_id:04X}" for b in config.boards if b.board_id not in boards]
    if missing:
        raise UsageError(f"no open board for the configured ID(s) {', '.join(missing)}")
    context = Context(session, config.domain_id)
    nodes = [
        BoardNode(context, config, board_config, boards[board_config.board_id])
        for board_config in config.boards
    ]
    try:
        async with anyio.create_task_group() as tg:
            for node in nodes:
                await tg.start(node.run)
            task_status.started(nodes)
    finally:
        for node in nodes:
            node.close()


class BoardNode(Outputs, Inputs):
    """One board as the ROS 2 node ``<namespace>/<name>``: its outputs
    (:class:`~._outputs.Outputs`), inputs (:class:`~._inputs.Inputs`, and the stream's,
    :class:`~._stream.StreamedInputs`) and diagnostics."""

    def __init__(
        self, context: Context, bridge: BridgeConfig, config: BoardConfig, board: Board
    ) -> None:
        self.config = config
        self.board = board
        self.node = Node(context, bridge.namespace, config.name)
        self.clock = BoardClock()
        self.outputs: list[_Command] = []
        self.published = 0
        self.command_errors = 0
        self.rc_lost: set[str] = set()
        #: Called as ``on_change(topic, sequence, stamp_ns, decoded_ns)`` after each change
        #: an input published: its attachment's sequence number, the board's time of the
        #: edge in host nanoseconds (:class:`BoardClock`) and the host time its frame was
        #: decoded (``time.time_ns()`` scale); for measurements and logging.
        self.on_change: Callable[[str, int, int, int], None] | None = None
        self._diagnostics = self.node.publisher(DIAGNOSTICS_TOPIC, msgs.DIAGNOSTIC_ARRAY)
        #: The board's firmware-timed stream, when an input comes from it.
        self.stream: StreamedInputs | None = None

    def close(self) -> None:
        """Take the node off the graph: undeclare its tokens, publishers, subscribers."""
        self.node.close()

    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Set up every configured pin, then publish and follow commands until cancelled;
        ``task_status.started()`` once each input published its first value."""
        async with anyio.create_task_group() as tg:
            for output in self.config.outputs:
                command = await self._set_up_output(output)
                self.outputs.append(command)
                tg.start_soon(self._write_commands, command)
                if output.timeout is not None:
                    tg.start_soon(self._watch_freshness, command)
            if self.config.link_failsafe_ms is not None:
                await self._arm_link_failsafe(self.config.link_failsafe_ms)
            from_stream = streamed(self.config.inputs, self.config.stream_ms)
            for source in self.config.inputs:
                if source not in from_stream:
                    await tg.start(self._publish_input, source)
            if from_stream:
                self.stream = StreamedInputs(
                    self.board,
                    from_stream,
                    period_ms=self.config.stream_ms,
                    clock=self.clock,
                    frame_id=self.config.frame_id,
                    publisher=self._publisher,
                    put=self._put,
                    link_lost=self._link_lost,
                )
                await tg.start(self.stream.run)
            tg.start_soon(self._publish_diagnostics)
            task_status.started()

    # ---- diagnostics ---------------------------------------------------------------------

    async def _publish_diagnostics(self) -> None:
        while True:
            self._put(
                self._diagnostics,
                msgs.diagnostic_array(msgs.Stamp(time.time_ns()), [await self.status()]),
            )
            await anyio.sleep(self.config.diagnostics_period)

    async def status(self) -> msgs.Status:
        """The board's ``DiagnosticStatus``: ERROR when unplugged or its link failsafe
        fired, WARN while an output is in its safe state for want of commands or an RC
        input's signal is lost."""
        timed_out = [c.config.topic for c in self.outputs if c.timed_out]
        values = {
            "board_id": f"0x{self.config.board_id:04X}",
            "connected": str(bool(self.board.connected)).lower(),
            "link_failsafe_tripped": str(bool(self.board.failsafe_tripped)).lower(),
            "command_timeouts": " ".join(timed_out),
            "rc_signal_lost": " ".join(sorted(self.rc_lost)),
            "command_errors": str(self.command_errors),
            "published": str(self.published),
            "clock_drift_ppm": f"{self.clock.drift_ppm:.1f}",
        }
        try:
            values["temperature_c"] = f"{await self.board.temperature():.1f}"
            # The link's losses since it opened: what line noise and timeouts cost.
            stats = self.board.link.stats
            for name in ("timeouts", "lost_replies", "retries", "resyncs", "garbage_bytes"):
                values[f"link_{name}"] = str(getattr(stats, name))
        except ArduinoIOError as exc:
            values.setdefault("temperature_c", f"unknown ({exc})")
        if not self.board.connected or self.board.failsafe_tripped:
            level, text = msgs.DIAG_ERROR, "board unplugged or link failsafe fired"
        elif timed_out:
            level, text = msgs.DIAG_WARN, "no fresh command: safe state on " + ", ".join(timed_out)
        elif self.rc_lost:
            level, text = msgs.DIAG_WARN, "RC signal lost on " + ", ".join(sorted(self.rc_lost))
        else:
            level, text = msgs.DIAG_OK, "ok"
        name = f"{self.node.namespace.rstrip('/')}/{self.config.name}"
        return msgs.Status(level, name, text, values["board_id"], values)
