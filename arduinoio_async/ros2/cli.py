"""``arduinoio ros2 --config robot.yaml``: this machine's boards as ROS 2 nodes.

Finds the configured boards (a :class:`BoardManager`: USB Unos, ``--ports``,
``ARDUINOIO_PORTS``), opens a Zenoh session in peer mode that connects to the robot's
Zenoh router (``--connect``, by default ``tcp/127.0.0.1:7447``, where
``ros2 run rmw_zenoh_cpp rmw_zenohd`` listens) and runs the bridge until interrupted.
Once every node is up it prints one JSON line ``{"nodes": [...], "connect": [...]}``
(scripts and tests wait for it).  A wrong configuration or a board that does not turn
up is one line on stderr and exit code 1; a missing ``ros2`` extra exit code 2.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

import anyio
import zenoh

from ..manager import BoardManager
from ..network import zenoh_config
from ..protocol import DEFAULT_BAUD
from ..transport import run as run_event_loop  # uvloop when installed
from ._bridge import run_bridge
from ._config import BridgeConfig, load

__all__ = ["build_parser", "main"]

log = logging.getLogger(__name__)

#: Where rmw_zenoh's router listens by default (its DEFAULT_RMW_ZENOH_SESSION_CONFIG).
DEFAULT_ROUTER = "tcp/127.0.0.1:7447"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arduinoio ros2",
        description="Run this machine's boards as ROS 2 nodes over rmw_zenoh (no ROS install).",
    )
    parser.add_argument("--config", type=Path, required=True, help="the bridge's YAML file")
    parser.add_argument(
        "--ports",
        action="append",
        default=[],
        metavar="PATH_OR_GLOB",
        help="also probe these ports (repeatable; ARDUINOIO_PORTS works too)",
    )
    parser.add_argument("--no-usb", action="store_true", help="do not probe USB serial ports")
    parser.add_argument("--baud", type=int, default=DEFAULT_BAUD)
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="the Zenoh router of the ROS 2 graph (repeatable; default "
        f"{DEFAULT_ROUTER} unless --listen or --zenoh-config says otherwise)",
    )
    parser.add_argument(
        "--listen", action="append", default=[], metavar="ENDPOINT", help="also listen here"
    )
    parser.add_argument(
        "--zenoh-config", type=Path, help="Zenoh JSON5 config file (TLS, access control, ...)"
    )
    parser.add_argument(
        "--wait", type=float, default=10.0, help="seconds to wait for each configured board"
    )
    parser.add_argument("-v", "--verbose", action="store_true")
    return parser


async def bridge(args: argparse.Namespace, config: BridgeConfig) -> None:
    """Find the boards, open the session, run the bridge until cancelled."""
    given = args.connect or args.listen or args.zenoh_config
    connect = list(args.connect) or ([] if given else [DEFAULT_ROUTER])
    zconfig = zenoh_config(listen=args.listen, connect=connect, config_file=args.zenoh_config)
    async with BoardManager(patterns=args.ports, usb=not args.no_usb, baudrate=args.baud) as found:
        boards = {b.board_id: await found.get(b.board_id, timeout=args.wait) for b in config.boards}
        session = await anyio.to_thread.run_sync(zenoh.open, zconfig)
        try:
            async with anyio.create_task_group() as tg:
                nodes = await tg.start(run_bridge, session, config, boards)
                names = [f"{n.node.namespace.rstrip('/')}/{n.config.name}" for n in nodes]
                print(json.dumps({"nodes": names, "connect": connect}), flush=True)
        finally:
            await anyio.to_thread.run_sync(session.close)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command; errors propagate to :func:`arduinoio_async.cli._entry.run_command`,
    which prints one line and picks the exit code."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    config = load(args.config)  # before any board is touched
    run_event_loop(bridge, args, config)
    return 0
