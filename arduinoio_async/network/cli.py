"""``arduinoio serve`` and the ``--remote`` option of the board commands.

``arduinoio serve [--ports P ...] [--listen ENDPOINT] [--connect ENDPOINT] [--config FILE]``
owns the boards it finds (a BoardManager: USB Unos, ``--ports``, ``ARDUINOIO_PORTS``) and
serves them until interrupted.  By default it listens on ``tcp/127.0.0.1:7447`` only and
does no multicast scouting; see ``docs/network.md`` for opening it to the robot network.
It prints one JSON line ``{"serving": [...], "listen": [...]}`` once the boards found at
start are served (scripts and tests wait for it), and logs connection events.
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

from ..errors import ArduinoIOError
from ..manager import BoardManager, add_ports_option
from ..protocol import DEFAULT_BAUD
from ..transport import run as run_event_loop  # uvloop when installed
from ._keys import DEFAULT_ENDPOINT, zenoh_config
from ._server import BoardServer

__all__ = ["build_parser", "listen_endpoints", "main", "serve"]

log = logging.getLogger(__name__)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="arduinoio serve",
        description="Serve the boards of this machine on the network (Zenoh).",
    )
    add_ports_option(parser)
    parser.add_argument("--no-usb", action="store_true", help="do not probe USB serial ports")
    parser.add_argument("--baud", type=int, default=DEFAULT_BAUD)
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"Zenoh endpoint to listen on (repeatable; default {DEFAULT_ENDPOINT})",
    )
    parser.add_argument(
        "--connect", action="append", default=[], metavar="ENDPOINT", help="peer or router"
    )
    parser.add_argument(
        "--config", type=Path, help="Zenoh JSON5 config file (TLS, access control, ...)"
    )
    parser.add_argument(
        "--rescan", type=float, default=1.0, help="seconds between scans for new boards"
    )
    parser.add_argument("-v", "--verbose", action="store_true")
    return parser


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """Where a session opened with ``config`` listens: the effective configuration (the
    ``--config`` file with ``--listen`` over it), for the ready line."""
    listen = json.loads(config.get_json("listen/endpoints"))
    if isinstance(listen, dict):  # Zenoh's per-mode form: {"router": [...], "peer": [...]}
        listen = listen.get(json.loads(config.get_json("mode")) or "peer", [])
    return [str(endpoint) for endpoint in listen or []]


async def serve(args: argparse.Namespace) -> None:
    """Run the server until cancelled."""
    listen = list(args.listen) or ([] if args.config else [DEFAULT_ENDPOINT])
    config = zenoh_config(listen=listen, connect=args.connect, config_file=args.config)
    listen = listen_endpoints(config)
    session = await anyio.to_thread.run_sync(zenoh.open, config)
    try:
        async with BoardManager(
            patterns=args.ports,
            usb=not args.no_usb,
            baudrate=args.baud,
            rescan_interval=args.rescan,
        ) as boards:
            # The manager logs its events itself (once each: a second log line here made
            # every event appear twice).
            server = BoardServer(boards, session)
            async with anyio.create_task_group() as tg:
                await tg.start(server.run)
                ready = {
                    "serving": [f"0x{bid:04X}" for bid in sorted(server.served)],
                    "listen": listen,
                }
                print(json.dumps(ready), flush=True)
    finally:
        await anyio.to_thread.run_sync(session.close)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        run_event_loop(serve, args)
    except ArduinoIOError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except zenoh.ZError as exc:
        print(f"error: zenoh: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
