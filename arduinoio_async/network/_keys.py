"""The key space, the Zenoh configuration and how link faults travel.

Key space (one board ID = four lowercase hex digits, ``0x0007`` -> ``0007``)::

    arduinoio/board/0007/server/<zid>
                                  liveliness token: the server ``<zid>`` (its Zenoh
                                  session ID) serves the board right now; one token per
                                  server, so a client sees two servers announcing one ID
    arduinoio/board/0007/rq       queryable: payload = one request frame, reply = the
                                  board's reply frame (an error reply ``CT|0x80 DT code CS``
                                  is a reply frame too); a link fault is a Zenoh error
                                  reply (see :func:`encode_fault`)
    arduinoio/board/0007/ev       publications: the board-initiated frames (class 0x40:
                                  stream samples with their sequence numbers, failsafe
                                  trips), byte for byte as the board sent them
    arduinoio/board/0007/conn     publications: the server's connection events (JSON)
    arduinoio/client/<zid>        liveliness token of a client session

Frames cross the network exactly as they cross the serial line, so the client's sans-IO
core decodes them, checks every echo and maps every error code as it does locally.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import zenoh

from ..errors import (
    ArduinoIOError,
    BoardTimeoutError,
    LinkResyncError,
    ProtocolError,
    ReplyMismatchError,
    UsageError,
)

__all__ = [
    "ALL_BOARDS",
    "ALL_CLIENTS",
    "DEFAULT_ENDPOINT",
    "RemoteFault",
    "announcement_from_key",
    "announcement_key",
    "board_key",
    "client_key",
    "connection_key",
    "decode_fault",
    "encode_fault",
    "events_key",
    "request_key",
    "undeclare",
    "zenoh_config",
]

#: Where ``arduinoio serve`` listens and clients connect by default: this machine only.
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
#: How long a silent peer counts as alive (ms).  Zenoh's default is 10 s; a shorter lease
#: lets the server notice a dead client (pulled cable, frozen machine) sooner.
DEFAULT_LEASE_MS = 1000

PREFIX = "arduinoio"
ALL_BOARDS = f"{PREFIX}/board/*/server/*"
ALL_CLIENTS = f"{PREFIX}/client/*"


def board_key(board_id: int) -> str:
    return f"{PREFIX}/board/{board_id:04x}"


def request_key(board_id: int) -> str:
    return f"{board_key(board_id)}/rq"


def events_key(board_id: int) -> str:
    return f"{board_key(board_id)}/ev"


def connection_key(board_id: int) -> str:
    return f"{board_key(board_id)}/conn"


def client_key(client_id: str) -> str:
    return f"{PREFIX}/client/{client_id}"


def announcement_key(board_id: int, server_id: str) -> str:
    """The liveliness token of server ``server_id`` serving board ``board_id``."""
    return f"{board_key(board_id)}/server/{server_id}"


def announcement_from_key(key: str) -> tuple[int, str] | None:
    """(board ID, server) of an announcement token's key, or None for anything else."""
    parts = key.split("/")
    if (
        len(parts) != 5
        or parts[:2] != [PREFIX, "board"]
        or parts[3] != "server"
        or len(parts[2]) != 4
        or not parts[4]
    ):
        return None
    try:
        return int(parts[2], 16), parts[4]
    except ValueError:
        return None


@dataclass(frozen=True, slots=True)
class RemoteFault:
    """A link failure on the server: ``error`` names the library's exception class."""

    error: str
    message: str

    @property
    def disconnected(self) -> bool:
        """Whether the failure means the server lost the board (its port closed or went to
        another program), not only that this one request failed."""
        return self.error in ("BoardDisconnectedError", "PortBusyError")

    def as_error(self, where: str) -> ArduinoIOError:
        """The exception the server's caller got, for the client's caller of the request.

        The classes whose outcome the server knows for this one request keep their class
        (a request that timed out there times out here; a request the server refused is
        refused); any other failure leaves the request's fate unknown:
        :class:`LinkResyncError`, as a local link says for a request in flight when it
        lost sync.
        """
        exact = _RELAYED.get(self.error, LinkResyncError)
        return exact(f"{where}: {self.message} ({self.error} on the server)")


#: Server-side failures that reach the client with their own class (constructors that
#: take a message only).
_RELAYED: dict[str, type[ArduinoIOError]] = {
    cls.__name__: cls
    for cls in (BoardTimeoutError, LinkResyncError, ReplyMismatchError, ProtocolError, UsageError)
}


def encode_fault(exc: BaseException) -> bytes:
    return json.dumps({"error": type(exc).__name__, "message": str(exc)}).encode()


def decode_fault(payload: bytes) -> RemoteFault:
    try:
        data = json.loads(payload)
        return RemoteFault(str(data["error"]), str(data["message"]))
    except (ValueError, KeyError, TypeError):
        return RemoteFault("LinkError", payload.decode(errors="replace"))


def undeclare(entity: object) -> None:
    """Undeclare a Zenoh entity; a no-op once its session is closed."""
    with contextlib.suppress(zenoh.ZError):
        entity.undeclare()  # type: ignore[attr-defined]


def zenoh_config(
    *,
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    config_file: str | Path | None = None,
) -> zenoh.Config:
    """A peer-mode configuration: explicit endpoints only, no multicast scouting.

    With ``config_file`` (Zenoh's JSON5 format: TLS, mutual TLS, access control...) the
    file is the base and only endpoints given here override it; without one, nothing
    listens unless ``listen`` says so, and nobody is found except through ``connect``.
    """
    if config_file is not None:
        config = zenoh.Config.from_file(str(config_file))
    else:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("listen/endpoints", "[]")
        config.insert_json5("transport/link/tx/lease", str(DEFAULT_LEASE_MS))
    if listen:
        config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    if connect:
        config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    return config
