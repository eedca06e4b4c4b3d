"""``arduinoio monitor``: a live page for one board (``--port``/``--id``) or every board found.

The command only finds boards and hands them to :func:`~._server.serve_monitor`; the
manager keeps supervising them, so a board that is reset or replugged comes back on the
same page.  It runs until interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import importlib.util
import signal
from collections.abc import AsyncIterator, Sequence
from contextlib import AsyncExitStack, asynccontextmanager

import anyio
from rich.console import Console

from ..board import Board
from ..errors import ArduinoIOError, UsageError
from ..manager import BoardManager
from ..network.options import add_remote_options, remote_board
from ..scan_options import add_scan_options, board_id
from ..transport import run as run_event_loop  # uvloop when installed

__all__ = ["build_parser", "main"]

INSTALL_HINT = "the monitor needs its extra: pip install 'arduinoio_async[monitor]'"


def build_parser(prog: str = "arduinoio monitor") -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Serve a live page of the boards: every pin, live plots, controls.",
    )
    parser.add_argument("--port", help="serial port or pyserial URL of the board")
    parser.add_argument("--id", type=board_id, help="board ID to look for on all ports")
    add_remote_options(parser)  # --remote --id N: a board served by `arduinoio serve`
    parser.add_argument(
        "--http",
        default="127.0.0.1:8000",
        metavar="HOST:PORT",
        help="where to serve the page (default 127.0.0.1:8000; other hosts need a token)",
    )
    parser.add_argument(
        "--token", help="token for a non-loopback --http (default: a random one, printed)"
    )
    parser.add_argument(
        "--period-ms", type=float, default=20.0, help="stream period of the board (default 20)"
    )
    parser.add_argument(
        "--no-stream",
        dest="stream",
        action="store_false",
        help="leave the sample stream off: inputs follow their change events only, no plots",
    )
    add_scan_options(parser)
    return parser


@asynccontextmanager
async def _boards(args: argparse.Namespace) -> AsyncIterator[list[Board]]:
    if args.remote:
        # Remote boards are Board objects too: the rest of the monitor is unchanged.
        if args.port:
            raise UsageError("--remote and --port name a board twice: give --remote --id N")
        async with remote_board(args) as board:
            yield [board]
        return
    if args.port and args.id is not None:
        raise UsageError("--port and --id name a board twice: give one of them")
    if args.port:
        async with Board.open(args.port, baudrate=args.baud, ready_timeout=args.probe_timeout) as b:
            yield [b]
        return
    async with BoardManager(
        patterns=args.ports, baudrate=args.baud, probe_deadline=args.probe_timeout
    ) as manager:
        if args.id is not None:
            yield [await manager.get(args.id, timeout=args.probe_timeout)]
            return
        found = sorted(manager.present().items())
        if not found:
            tried = "; ".join(
                f"{port}: {r.error or 'no answer'}" for port, r in sorted(manager.probed().items())
            )
            raise ArduinoIOError(
                f"no boards found (tried {tried or 'no ports: pass --port or --ports'})"
            )
        yield [board for _id, board in found]


async def _monitor(args: argparse.Namespace, console: Console) -> int:
    from ._server import is_loopback, new_token, parse_http, serve_monitor

    host, _port = parse_http(args.http)
    token = args.token or (None if is_loopback(host) else new_token())
    async with AsyncExitStack() as stack:
        with console.status("looking for boards..."):
            boards = await stack.enter_async_context(_boards(args))
        server = await stack.enter_async_context(
            serve_monitor(
                boards, http=args.http, token=token, period_ms=args.period_ms, stream=args.stream
            )
        )
        names = ", ".join(f"0x{b.board_id:04X} on {b.port}" for b in boards)
        console.print(f"monitoring {names}")
        console.print(f"open [bold]{server.url}[/] (Ctrl-C stops)", soft_wrap=True)
        with anyio.open_signal_receiver(signal.SIGINT, signal.SIGTERM) as signals:
            async for _signal in signals:
                break
    console.print("monitor stopped")
    return 0


def main(argv: Sequence[str], *, console: Console | None = None) -> int:
    """Run ``arduinoio monitor`` with ``argv``; returns the exit code."""
    console = console or Console()
    errors = Console(stderr=True)
    args = build_parser().parse_args(list(argv))
    if importlib.util.find_spec("starlette") is None or importlib.util.find_spec("uvicorn") is None:
        errors.print(f"[red]error:[/] {INSTALL_HINT}", highlight=False)
        return 2
    try:
        return run_event_loop(_monitor, args, console)
    except ArduinoIOError as exc:
        errors.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return 1
    except KeyboardInterrupt:
        return 130
