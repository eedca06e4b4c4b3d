"""rmw_zenoh's wire format as pure functions: key expressions, liveliness tokens, attachments.

Everything a ROS 2 node using ``rmw_zenoh_cpp`` needs to see on a Zenoh network to list a
node and its topics (``ros2 node list``, ``ros2 topic list``) and to take its messages,
written down in ``docs/ros2.md`` with its sources (rmw_zenoh's ``docs/design.md``,
``liveliness_utils.cpp``, ``attachment_helpers.cpp``; Jazzy >= 0.2.4 and Kilted >= 0.6.0):

* data: ``<domain>/<topic without its leading slash>/<pkg>::msg::dds_::<Name>_/RIHS01_<hex>``;
* graph: one liveliness token per node (``NN``), publisher (``MP``) and subscription
  (``MS``) under ``@ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/<enclave>/<ns>/<node>``,
  every ``/`` inside a name replaced by ``%``;
* attachment of every sample: sequence number, source timestamp (ns since the UNIX
  epoch) and the publisher's 16-byte GID, in zenoh-ext serialization (``zenoh.ext``
  writes it; nothing here packs bytes by hand).

No I/O here, so the unit tests compare these against byte-level vectors.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from enum import Enum

from zenoh import ZBytes
from zenoh.ext import Int64, z_deserialize, z_serialize

from ..errors import UsageError

__all__ = [
    "ADMIN_SPACE",
    "GID_SIZE",
    "Attachment",
    "EntityKind",
    "Qos",
    "dds_type_name",
    "decode_attachment",
    "encode_attachment",
    "endpoint_token",
    "fully_qualified",
    "gid_of",
    "graph_key",
    "mangle",
    "node_token",
    "topic_key",
]

#: The key prefix of every graph token (``liveliness_utils.cpp``: ``ADMIN_SPACE``).
ADMIN_SPACE = "@ros2_lv"
#: A fully qualified ROS name (REP 144 without ``~`` and substitutions).
_ROS_NAME = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
#: ``RMW_GID_STORAGE_SIZE``.
GID_SIZE = 16


class EntityKind(Enum):
    """The entity field of a liveliness token."""

    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"


def mangle(name: str) -> str:
    """A ROS name as one key chunk: every ``/`` becomes ``%`` (``mangle_name``)."""
    return name.replace("/", "%")


def fully_qualified(namespace: str, name: str) -> str:
    """The absolute topic name of ``name`` (relative or absolute) in ``namespace``.

    Plain ROS name resolution without ``~`` or remapping: ``("/robot", "led")`` ->
    ``/robot/led``; an absolute ``/diagnostics`` stays as it is.
    """
    resolved = name if name.startswith("/") else namespace.rstrip("/") + "/" + name
    if not _ROS_NAME.fullmatch(resolved):
        raise UsageError(
            f"not a valid ROS name: {name!r} in namespace {namespace!r} (letters, digits"
            " and _ between single slashes, no token starting with a digit)"
        )
    return resolved


def dds_type_name(ros_type: str) -> str:
    """``std_msgs/msg/Bool`` -> ``std_msgs::msg::dds_::Bool_`` (``type_support_common.cpp``)."""
    parts = ros_type.split("/")
    if len(parts) != 3 or not all(parts):
        raise UsageError(f"not a ROS type name like std_msgs/msg/Bool: {ros_type!r}")
    package, kind, name = parts
    return f"{package}::{kind}::dds_::{name}_"


def topic_key(domain_id: int, topic: str, ros_type: str, type_hash: str) -> str:
    """The key expression a topic's samples travel on.

    ``topic`` is the fully qualified name; one leading slash goes (``strip_slashes``),
    inner slashes stay, so ``/robot/led`` lives at ``0/robot/led/...``.
    """
    return f"{domain_id}/{topic.strip('/')}/{dds_type_name(ros_type)}/{type_hash}"


@dataclass(frozen=True)
class Qos:
    """The QoS a token advertises; every component equal to rmw_zenoh's default is
    written empty (``qos.cpp``), so the default profile with depth 10 is ``::,10:,:,:,,``.

    Only what this bridge offers: reliable or best effort, volatile, keep last ``depth``.
    """

    depth: int = 10
    best_effort: bool = False

    def key(self) -> str:
        # <reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,<ns>:
        # <liveliness>,<lease s>,<ns>; RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT is 2.
        reliability = "2" if self.best_effort else ""
        return f"{reliability}::,{self.depth}:,:,:,,"


def node_token(
    domain_id: int, zid: str, node_id: int, namespace: str, node: str, enclave: str = ""
) -> str:
    """The liveliness token of a node (its id repeats in the entity field)."""
    return (
        f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{node_id}/{EntityKind.NODE.value}/"
        f"{mangle(enclave) or '%'}/{mangle(namespace) or '%'}/{mangle(node)}"
    )


def endpoint_token(
    domain_id: int,
    zid: str,
    node_id: int,
    entity_id: int,
    kind: EntityKind,
    namespace: str,
    node: str,
    topic: str,
    ros_type: str,
    type_hash: str,
    qos: Qos,
    enclave: str = "",
) -> str:
    """The liveliness token of a publisher or a subscription of ``node``."""
    return (
        f"{ADMIN_SPACE}/{domain_id}/{zid}/{node_id}/{entity_id}/{kind.value}/"
        f"{mangle(enclave) or '%'}/{mangle(namespace) or '%'}/{mangle(node)}/"
        f"{mangle(topic)}/{dds_type_name(ros_type)}/{type_hash}/{qos.key()}"
    )


def graph_key(domain_id: int) -> str:
    """Every graph token of a domain (what ``ros2 node list`` subscribes to)."""
    return f"{ADMIN_SPACE}/{domain_id}/**"


def gid_of(token: str) -> bytes:
    """A 16-byte GID for the entity announced by ``token``.

    rmw_zenoh derives it from a hash of the token (XXH3-128); a GID is opaque to every
    receiver (it tells publishers apart, nobody recomputes it), so the first 16 bytes of
    the token's SHA-256 serve as well without another dependency.
    """
    return hashlib.sha256(token.encode()).digest()[:GID_SIZE]


@dataclass(frozen=True)
class Attachment:
    """What rides beside every sample."""

    #: Per publisher, from 1.
    sequence: int
    #: Nanoseconds since the UNIX epoch when the sample was published.
    timestamp_ns: int
    gid: bytes


def encode_attachment(attachment: Attachment) -> bytes:
    """The 33 bytes of ``attachment``: int64 LE, int64 LE, LEB128 length 16, the GID."""
    if len(attachment.gid) != GID_SIZE:
        raise UsageError(f"a GID is {GID_SIZE} bytes, not {len(attachment.gid)}")
    items = (Int64(attachment.sequence), Int64(attachment.timestamp_ns), attachment.gid)
    return z_serialize(items).to_bytes()


def decode_attachment(data: bytes) -> Attachment:
    """The attachment in ``data``; raises UsageError when it is not rmw_zenoh's layout."""
    try:
        sequence, stamp, gid = z_deserialize(tuple[Int64, Int64, bytes], ZBytes(data))
    except Exception as exc:  # zenoh raises ZDeserializeError or ValueError
        raise UsageError(f"not an rmw_zenoh attachment ({len(data)} bytes): {exc}") from None
    if len(gid) != GID_SIZE:
        raise UsageError(f"attachment GID is {len(gid)} bytes, not {GID_SIZE}")
    return Attachment(int(sequence), int(stamp), bytes(gid))
