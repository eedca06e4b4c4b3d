"""The monitor's web application (Starlette): one page, its static files, one WebSocket.

Who may connect:

* Bound to a loopback address, only this machine can reach the server; the Host header
  must name a loopback host too (``localhost``, ``127.0.0.1``, ``::1`` or the address it
  is bound to, say ``127.0.0.2``), so a web page on the Internet cannot reach it through
  DNS rebinding.
* Bound to any other address, the page and the WebSocket need the server's token
  (``?token=...``; the page passes it on to the WebSocket).  Static files (our script,
  style and the plotting library) are public: they hold no data and no controls.
* A WebSocket whose ``Origin`` is not the page's own host is refused, so another site
  open in the same browser cannot drive the board.

What a page may send: JSON text messages of at most :data:`MAX_MESSAGE` bytes (a longer
one closes that page's connection with code 1009 before it is read whole), each one
object.  Anything else -- a binary frame, text that is not JSON, a number beyond a
float's range (``Infinity``, ``1e400``), an integer too long to convert, nesting too deep
to parse -- gets a one-line ``result`` error (``"id"`` as given, if it could be read)
and a log line, and the page's connection goes on: a bad message is a bad request, not
a reason to drop the page or to print a traceback.
"""

from __future__ import annotations

import hmac
import json
import logging
import math
from pathlib import Path
from urllib.parse import urlsplit

import anyio
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, PlainTextResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

from ._hub import MonitorHub

__all__ = [
    "LOOPBACK_HOSTS",
    "MAX_MESSAGE",
    "STATIC_DIR",
    "VENDOR_FILES",
    "BadMessage",
    "create_app",
    "missing_assets",
    "parse_request",
]

logger = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).resolve().parent / "static"
#: Files that ``make monitor-assets`` installs through npm (see docs/monitor.md).
VENDOR_FILES = ("vendor/uPlot.iife.min.js", "vendor/uPlot.min.css")
LOOPBACK_HOSTS = ["127.0.0.1", "localhost", "::1", "[::1]"]
#: Control requests of one page that may be in progress at once.
PAGE_CONCURRENCY = 8
#: Bytes of one message from a page at most (its controls take a few dozen).
MAX_MESSAGE = 64 * 1024


class BadMessage(ValueError):
    """A page's message that is not a request; ``str()`` is the one line the page gets."""

    def __init__(self, reason: str, request_id: object = None) -> None:
        super().__init__(reason)
        self.request_id = request_id


def _refuse_constant(name: str) -> object:
    raise BadMessage(f"{name} is not a number a control takes")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise BadMessage(f"{text[:20]} is beyond a float's range")
    return value


def parse_request(text: str) -> dict[str, object]:
    """One page message as a request object, or :class:`BadMessage` saying why not.

    Non-finite numbers are refused while parsing, so no control meets an ``inf`` that
    ``int()`` cannot convert; deep nesting and integers of more digits than Python
    converts fail in the parser with errors other than ``JSONDecodeError``.
    """
    try:
        request = json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float)
    except BadMessage:
        raise
    except RecursionError:
        raise BadMessage("the message nests too deeply") from None
    except json.JSONDecodeError as exc:
        raise BadMessage(f"not JSON: {exc.msg} at character {exc.pos}") from None
    except ValueError as exc:  # e.g. an integer of more digits than int() converts
        raise BadMessage(f"not a request: {str(exc).split(':')[0]}") from None
    if not isinstance(request, dict):
        raise BadMessage(f"a request is a JSON object, not {type(request).__name__}")
    return request


def missing_assets() -> list[str]:
    """Vendor files that are not installed (an empty list when the page can work)."""
    return [name for name in VENDOR_FILES if not (STATIC_DIR / name).is_file()]


def _token_ok(given: str | None, token: str | None) -> bool:
    if token is None:
        return True
    return given is not None and hmac.compare_digest(given.encode(), token.encode())


def _same_origin(websocket: WebSocket) -> bool:
    origin = websocket.headers.get("origin")
    if origin is None:
        return True  # not a browser: the host and token checks apply
    return urlsplit(origin).netloc.lower() == websocket.headers.get("host", "").lower()


async def _receive_text(websocket: WebSocket) -> str:
    """The next text message; a binary one is a :class:`BadMessage` (Starlette's
    ``receive_text`` fails on it with a ``KeyError``)."""
    message = await websocket.receive()
    if message["type"] == "websocket.disconnect":
        raise WebSocketDisconnect(message.get("code", 1000), message.get("reason"))
    text = message.get("text")
    if text is None:
        raise BadMessage("binary messages are not understood: send JSON text")
    return str(text)


def create_app(
    hub: MonitorHub, *, token: str | None = None, loopback: bool = True, host: str = ""
) -> Starlette:
    """The ASGI app serving ``hub``; ``token`` is required unless bound to loopback
    (``host``: the loopback address it is bound to, also a valid Host header)."""
    index_html = (STATIC_DIR / "index.html").read_text(encoding="utf-8")

    async def index(request: Request) -> Response:
        if not _token_ok(request.query_params.get("token"), token):
            return PlainTextResponse("this monitor needs its token: open the URL it printed", 403)
        return HTMLResponse(index_html, headers={"Cache-Control": "no-store"})

    async def socket(websocket: WebSocket) -> None:
        if not _token_ok(websocket.query_params.get("token"), token) or not _same_origin(websocket):
            await websocket.close(code=1008)
            return
        await websocket.accept()
        subscriber = hub.subscribe()
        slots = anyio.Semaphore(PAGE_CONCURRENCY)

        async def send_all(scope: anyio.CancelScope) -> None:
            try:
                async for message in subscriber.messages:
                    await websocket.send_text(json.dumps(message))
                await websocket.close(code=1013)  # fell behind: the page reconnects
            except (WebSocketDisconnect, OSError, RuntimeError):
                pass  # the page went away mid-send
            scope.cancel()

        async def answer(request: dict[str, object]) -> None:
            try:
                # A control runs to its end even if the page closes meanwhile: a role change
                # or a reset cut in half would leave the board in neither state.
                with anyio.CancelScope(shield=True):
                    subscriber.offer(await hub.perform(request))
            finally:
                slots.release()

        def refuse(bad: BadMessage) -> None:
            logger.info("monitor: a page's message refused: %s", bad)
            subscriber.offer(
                {"type": "result", "id": bad.request_id, "op": None, "ok": False, "error": str(bad)}
            )

        try:
            async with anyio.create_task_group() as tg:
                tg.start_soon(send_all, tg.cancel_scope)
                while True:
                    try:
                        request = parse_request(await _receive_text(websocket))
                    except BadMessage as bad:
                        refuse(bad)
                        continue
                    await slots.acquire()  # back-pressure on a page that floods
                    tg.start_soon(answer, request)
        except* WebSocketDisconnect:
            pass  # the page closed (or was closed after falling behind)
        finally:
            hub.unsubscribe(subscriber)

    middleware = []
    if loopback:
        bound = [host, f"[{host}]"] if host else []
        allowed = [*LOOPBACK_HOSTS, *bound]
        middleware.append(Middleware(TrustedHostMiddleware, allowed_hosts=allowed))
    return Starlette(
        routes=[
            Route("/", index),
            WebSocketRoute("/ws", socket),
            Mount("/static", StaticFiles(directory=STATIC_DIR), name="static"),
        ],
        middleware=middleware,
    )
