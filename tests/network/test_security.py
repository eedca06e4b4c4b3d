"""Defaults that keep the boards off the network, and TLS + access control from a file."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import anyio
import pytest
import zenoh

from arduinoio_async.errors import BoardNotFoundError, UsageError
from arduinoio_async.network import DEFAULT_ENDPOINT, open_remote_board, parse_board_url
from arduinoio_async.network import zenoh_config as make_config
from arduinoio_async.network._keys import (
    announcement_from_key,
    announcement_key,
    board_key,
    request_key,
)

from .conftest import ServeFactory

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_by_default_nothing_listens_and_nobody_is_scouted() -> None:
    config = make_config()
    assert json.loads(config.get_json("listen/endpoints")) == []
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert DEFAULT_ENDPOINT == "tcp/127.0.0.1:7447"
    served = make_config(listen=[DEFAULT_ENDPOINT])
    assert json.loads(served.get_json("listen/endpoints")) == [DEFAULT_ENDPOINT]


def test_the_documented_robot_config_parses() -> None:
    config = zenoh.Config.from_file(str(DOCS / "network-robot.json5"))
    assert json.loads(config.get_json("transport/link/tls/enable_mtls")) is True
    assert json.loads(config.get_json("access_control/default_permission")) == "deny"
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False


def test_board_urls_and_keys() -> None:
    assert parse_board_url("zenoh://0x0007") == (7, [])
    assert parse_board_url("zenoh://7@tls/10.0.0.2:7447") == (7, ["tls/10.0.0.2:7447"])
    for bad in ("serial://7", "zenoh://seven", "zenoh://0x10000"):
        with pytest.raises(UsageError):
            parse_board_url(bad)
    assert board_key(0xBEEF) == "arduinoio/board/beef"
    assert request_key(7) == "arduinoio/board/0007/rq"
    assert announcement_key(7, "ab12") == "arduinoio/board/0007/server/ab12"
    assert announcement_from_key("arduinoio/board/0007/server/ab12") == (7, "ab12")
    assert announcement_from_key("arduinoio/board/0007") is None
    assert announcement_from_key("arduinoio/board/0007/rq") is None
    assert announcement_from_key("arduinoio/board/zzzz/server/ab12") is None


async def openssl(*args: str) -> None:
    await anyio.run_process(["openssl", *args], check=True)


async def certificate(directory: Path, name: str, common_name: str) -> None:
    """A key and a certificate for ``common_name`` (valid for 127.0.0.1), signed by the CA."""
    key, request, cert = (directory / f"{name}.{ext}" for ext in ("key", "csr", "pem"))
    await openssl(
        "req",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-subj",
        f"/CN={common_name}",
        "-keyout",
        str(key),
        "-out",
        str(request),
    )
    extensions = directory / f"{name}.ext"
    extensions.write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
    await openssl(
        "x509",
        "-req",
        "-in",
        str(request),
        "-CA",
        str(directory / "ca.pem"),
        "-CAkey",
        str(directory / "ca.key"),
        "-CAcreateserial",
        "-days",
        "2",
        "-extfile",
        str(extensions),
        "-out",
        str(cert),
    )


def tls_config(directory: Path, name: str, *, allowed: list[str]) -> Path:
    """A peer config like docs/network-robot.json5, for ``name``'s certificate."""
    config = {
        "mode": "peer",
        "listen": {"endpoints": []},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "transport": {
            "link": {
                "tls": {
                    "root_ca_certificate": str(directory / "ca.pem"),
                    "listen_private_key": str(directory / f"{name}.key"),
                    "listen_certificate": str(directory / f"{name}.pem"),
                    "enable_mtls": True,
                    "connect_private_key": str(directory / f"{name}.key"),
                    "connect_certificate": str(directory / f"{name}.pem"),
                    "verify_name_on_connect": True,
                }
            }
        },
        "access_control": {
            "enabled": True,
            "default_permission": "deny",
            "rules": [
                {
                    "id": "arduinoio",
                    "messages": [
                        "put",
                        "declare_subscriber",
                        "query",
                        "reply",
                        "declare_queryable",
                        "liveliness_token",
                        "liveliness_query",
                        "declare_liveliness_subscriber",
                    ],
                    "flows": ["ingress", "egress"],
                    "permission": "allow",
                    "key_exprs": ["arduinoio/**"],
                }
            ],
            "subjects": [{"id": "robot", "cert_common_names": allowed}],
            "policies": [{"id": "robot", "rules": ["arduinoio"], "subjects": ["robot"]}],
        },
    }
    path = directory / f"{name}.json5"
    path.write_text(json.dumps(config, indent=2))
    return path


@pytest.mark.sim
@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")
async def test_mutual_tls_and_access_control(serve_unos: ServeFactory, tmp_path: Path) -> None:
    await openssl(
        "req",
        "-x509",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-days",
        "2",
        "-subj",
        "/CN=robot-ca",
        "-keyout",
        str(tmp_path / "ca.key"),
        "-out",
        str(tmp_path / "ca.pem"),
    )
    robot = ["io-computer.robot", "planner.robot"]
    for name, common_name in (
        ("server", robot[0]),
        ("planner", robot[1]),
        ("intruder", "laptop.lab"),
    ):
        await certificate(tmp_path, name, common_name)
    server_config = tls_config(tmp_path, "server", allowed=robot)
    async with serve_unos([7], server_args=("--config", str(server_config))) as served:
        assert served.endpoint.startswith("tls/127.0.0.1:")
        planner = tls_config(tmp_path, "planner", allowed=robot)
        async with open_remote_board(7, connect=[served.endpoint], config_file=planner) as board:
            assert await board.read_id() == 7
        # A certificate of the robot's CA whose name the access control does not list:
        intruder = tls_config(tmp_path, "intruder", allowed=robot)
        with pytest.raises(BoardNotFoundError):
            async with open_remote_board(
                7, connect=[served.endpoint], config_file=intruder, ready_timeout=1.5
            ):
                pass
        # Plain TCP to a TLS-only server: nothing.
        with pytest.raises(BoardNotFoundError):
            async with open_remote_board(
                7, connect=[served.endpoint.replace("tls/", "tcp/")], ready_timeout=1.5
            ):
                pass
