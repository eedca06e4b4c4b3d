"""Board edge -> ROS 2 subscriber latency through the rmw_zenoh bridge (issue 30).

A virtual Uno (no 16U2 model, 1 Mbaud) with the harness driving D3; the bridge
(:func:`arduinoio_async.ros2.run_bridge`) publishes each change as ``std_msgs/Bool``;
zenoh-ros2-sdk in a separate process (``tests/ros2/sdk_peer.py``) subscribes and notes the
host time of each receipt.  The latency of an edge is that receipt time minus the board's
timestamp of the edge converted to host time by the bridge's ``BoardClock`` (both
``time.time_ns()`` on this machine; the conversion is late by the least transit it saw,
docs/ros2.md, so the figure is a slight underestimate of the true edge-to-receipt time).
Next to it, in the same run and the same Zenoh sessions: the plain Zenoh round trip
(put on ``bench/ping``, the peer puts it back on ``bench/pong``).

    .venv/bin/python -m benchmarks.ros2_latency --json benchmarks/results/ros2.json

(from the repository root: the peer and its driver are the tests' ``tests/ros2``).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import time
from pathlib import Path
from typing import Any

import anyio
import zenoh

from arduinoio_async.bench.stats import summarize
from arduinoio_async.board import Board
from arduinoio_async.network import zenoh_config
from arduinoio_async.ros2 import BoardClock, parse, run_bridge
from arduinoio_async.sim import VirtualUno
from benchmarks._results import command_line, report
from tests.ros2.conftest import Peer, free_port, sdk_peer

CONFIG = {
    "boards": [{"name": "uno", "id": 1, "inputs": [{"pin": "D3", "type": "bool", "topic": "d3"}]}]
}


def figures(samples_ms: list[float]) -> dict[str, Any]:
    """n, p50, p90, p99 and mean (arduinoio_async.bench.stats) and the maximum, in ms."""
    return {**summarize(samples_ms).rounded(3, "_ms"), "max_ms": round(max(samples_ms), 3)}


async def edges(
    uno: VirtualUno,
    peer: Peer,
    stamps: list[int],
    n: int,
    windows: list[tuple[int, int]],
    drive_to_receipt: list[float],
    stages: list[tuple[int, int]],
    split: dict[str, list[float]],
) -> list[float]:
    """Drive ``n`` edges on D3, one at a time; each one's edge-to-receipt latency (ms).

    ``windows`` gets, per edge, the stamp's place against the host's clock around the
    harness's drive command: (stamp - time before the command, time after its reply -
    stamp), both >= 0 when the converted stamp lies where the edge truly happened;
    ``drive_to_receipt`` the time (ms) from before the drive command to the receipt, which
    needs no clock estimate (and includes the harness's command round trip).
    ``split`` gets each edge's stages (ms): ``drive_to_decoded`` (the harness's command,
    the simulated board, the UART, the link's decoding), ``decoded_to_put`` (the change's
    way through the bridge: the watch's queue, the stamp conversion, CDR, the Zenoh put)
    and ``put_to_subscriber`` (Zenoh on loopback and the SDK's decoding in its process);
    ``decoded_to_subscriber`` is the whole way after the board's UART (the last two).
    """
    latencies = []
    level = True
    base = len(stamps)  # the bridge appends the stamp of each edge it publishes
    for index in range(base, base + n):
        before = time.time_ns()
        await uno.drive(3, level)
        after = time.time_ns()
        got = await peer.message(lambda m: m.get("topic") == "/uno/d3")
        assert got["data"] is level, (index, got)
        latencies.append((got["received_ns"] - stamps[index]) / 1e6)
        windows.append((stamps[index] - before, after - stamps[index]))
        drive_to_receipt.append((got["received_ns"] - before) / 1e6)
        decoded, put = stages[index]
        split["drive_to_decoded"].append((decoded - before) / 1e6)
        split["decoded_to_put"].append((put - decoded) / 1e6)
        split["put_to_subscriber"].append((got["received_ns"] - put) / 1e6)
        split["decoded_to_subscriber"].append((got["received_ns"] - decoded) / 1e6)
        level = not level
        await anyio.sleep(0.005)  # pacing between edges, not a wait for a condition
    return latencies


async def round_trips(session: zenoh.Session, n: int) -> list[float]:
    """``n`` plain Zenoh round trips (ms) through the peer's echo."""
    token = anyio.lowlevel.current_token()
    arrived = anyio.Event()

    def on_pong(sample: zenoh.Sample) -> None:
        anyio.from_thread.run_sync(arrived.set, token=token)

    subscriber = session.declare_subscriber("bench/pong", on_pong)
    publisher = session.declare_publisher("bench/ping")
    times = []
    try:
        for index in range(n + 20):  # the first 20 warm the route up
            arrived = anyio.Event()
            start = time.perf_counter()
            publisher.put(index.to_bytes(4, "little"))
            with anyio.fail_after(5):
                await arrived.wait()
            if index >= 20:
                times.append((time.perf_counter() - start) * 1e3)
            await anyio.sleep(0.002)
    finally:
        subscriber.undeclare()  # type: ignore[no-untyped-call]
        publisher.undeclare()  # type: ignore[no-untyped-call]
    return times


async def main(args: argparse.Namespace) -> dict[str, Any]:
    port = free_port()
    zconfig = zenoh_config(listen=[f"tcp/127.0.0.1:{port}"])
    session = await anyio.to_thread.run_sync(zenoh.open, zconfig)
    stamps: list[int] = []
    #: Per published edge: (host time its frame was decoded, time the put returned).
    stages: list[tuple[int, int]] = []
    try:
        async with (
            VirtualUno(board_id=1, usb_bridge="none") as uno,
            Board.open(uno.port, baudrate=uno.baud) as board,
            anyio.create_task_group() as tg,
        ):
            nodes = await tg.start(run_bridge, session, parse(CONFIG), {1: board})

            def on_change(topic: str, seq: int, stamp: int, decoded: int) -> None:
                stamps.append(stamp)
                stages.append((decoded, time.time_ns()))

            nodes[0].on_change = on_change
            nodes[0].clock = BoardClock(bucket_s=args.bucket_s, buckets=args.buckets)
            async with sdk_peer(port) as peer:
                await peer.subscribe("/uno/d3", "std_msgs/msg/Bool")
                await peer._send({"op": "echo"})
                await peer._answer("echoing")
                windows: list[tuple[int, int]] = []
                driven: list[float] = []
                split: dict[str, list[float]] = {
                    "drive_to_decoded": [], "decoded_to_put": [], "put_to_subscriber": [],
                    "decoded_to_subscriber": [],
                }  # fmt: skip
                # Warm-up (routes, the clock's first buckets), not recorded.
                await edges(uno, peer, stamps, 20, windows, driven, stages, split)
                del windows[:], driven[:]
                for values in split.values():
                    del values[:]
                ros: list[float] = []
                plain: list[float] = []
                for _ in range(args.rounds):  # interleaved: a busy moment hits both
                    ros += await edges(
                        uno, peer, stamps, args.n // args.rounds, windows, driven, stages, split
                    )
                    plain += await round_trips(session, args.n // args.rounds)
                drift = nodes[0].clock.drift_ppm
                spread = nodes[0].clock.spread_ns
            tg.cancel_scope.cancel()
    finally:
        await anyio.to_thread.run_sync(session.close)
    ros_figures, plain_figures = figures(ros), figures(plain)
    result: dict[str, Any] = {
        "command": command_line(),
        "machine": f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end",
        "zenoh": importlib.metadata.version("eclipse-zenoh"),
        "zenoh_ros2_sdk": importlib.metadata.version("zenoh-ros2-sdk"),
        "link": "virtual Uno, no 16U2 model, 1,000,000 baud; Zenoh TCP loopback",
        "edge_to_ros_subscriber": ros_figures,
        "drive_command_to_ros_subscriber": figures(driven),
        "plain_zenoh_round_trip": plain_figures,
        "stages": {name: figures(values) for name, values in split.items()},
        "board_clock": {
            "bucket_s": args.bucket_s,
            "buckets": args.buckets,
            "drift_ppm": round(drift, 1),
            "spread_us": round(spread / 1000, 1),
            # Against the harness: the edge happened between the drive command's send and
            # its reply; how far the converted stamp fell outside that window.
            "stamp_early_ms": figures([max(0, -early) / 1e6 for early, _ in windows]),
            "stamp_late_ms": figures([max(0, -late) / 1e6 for _, late in windows]),
            "drive_window_ms": figures([(e + lt) / 1e6 for e, lt in windows]),
        },
    }
    result["ratio_p50"] = round(ros_figures["p50_ms"] / plain_figures["p50_ms"], 2)
    # The way after the board's UART (no simulated board, no clock estimate in it) against
    # the same round trip: the part of the latency that is the bridge's and Zenoh's.
    after_uart = result["stages"]["decoded_to_subscriber"]["p50_ms"]
    result["ratio_after_uart_p50"] = round(after_uart / plain_figures["p50_ms"], 2)
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=1000, help="edges (and round trips)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--bucket-s", type=float, default=0.25, help="BoardClock's bucket (s)")
    parser.add_argument("--buckets", type=int, default=20, help="BoardClock's window (buckets)")
    args = parser.parse_args()
    report(anyio.run(main, args), args.json, indent=1)
