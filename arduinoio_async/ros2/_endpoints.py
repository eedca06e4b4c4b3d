"""ROS 2 publishers, subscriptions and nodes on a Zenoh session, the way rmw_zenoh makes them.

A :class:`Node` declares its ``NN`` liveliness token; each :class:`Publisher` declares its
``MP`` token and a Zenoh publisher on the topic's key and puts every payload with the
attachment (sequence from 1, publish time, GID); each subscription declares its ``MS``
token and a Zenoh subscriber whose callback runs in the event loop (``LoopHandle``).
Undeclaring the tokens (:meth:`Node.close`) takes the node off ``ros2 node list`` at once;
a killed process leaves it when Zenoh's lease ends.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Iterator
from typing import Any

import zenoh

from ..network._keys import undeclare
from ..network._loop import LoopHandle
from . import _messages
from ._wire import (
    Attachment,
    EntityKind,
    Qos,
    decode_attachment,
    encode_attachment,
    endpoint_token,
    gid_of,
    node_token,
    topic_key,
)

__all__ = ["Context", "Node", "Publisher"]

log = logging.getLogger(__name__)


class Context:
    """One Zenoh session as one ROS 2 context: the entity ids count across its nodes."""

    def __init__(self, session: zenoh.Session, domain_id: int) -> None:
        self.session = session
        self.domain_id = domain_id
        self.zid = str(session.info.zid())
        self._ids: Iterator[int] = itertools.count()

    def next_id(self) -> int:
        return next(self._ids)


class Node:
    """A ROS 2 node: ``namespace`` (``/`` or ``/robot``) and ``name``."""

    def __init__(self, context: Context, namespace: str, name: str) -> None:
        self.context = context
        self.namespace = namespace
        self.name = name
        self.node_id = context.next_id()
        self.token_key = node_token(context.domain_id, context.zid, self.node_id, namespace, name)
        self._undeclare: list[Any] = []
        self._declare_token(self.token_key)

    def _declare_token(self, key: str) -> None:
        self._undeclare.append(self.context.session.liveliness().declare_token(key))

    def _endpoint_token(self, kind: EntityKind, topic: str, ros_type: str, qos: Qos) -> str:
        key = endpoint_token(
            self.context.domain_id,
            self.context.zid,
            self.node_id,
            self.context.next_id(),
            kind,
            self.namespace,
            self.name,
            topic,
            ros_type,
            _messages.type_hash(ros_type),
            qos,
        )
        self._declare_token(key)
        return key

    def publisher(self, topic: str, ros_type: str, qos: Qos | None = None) -> Publisher:
        """A publisher of ``ros_type`` on the fully qualified ``topic``."""
        token = self._endpoint_token(EntityKind.PUBLISHER, topic, ros_type, qos or Qos())
        key = topic_key(self.context.domain_id, topic, ros_type, _messages.type_hash(ros_type))
        publisher = Publisher(self.context.session.declare_publisher(key), gid_of(token), key)
        self._undeclare.append(publisher.zenoh_publisher)
        return publisher

    def subscribe(
        self,
        topic: str,
        ros_type: str,
        on_message: Callable[[Any, Attachment | None], None],
        qos: Qos | None = None,
    ) -> None:
        """Call ``on_message(message, attachment)`` in the event loop for each sample on
        ``topic``; a sample that does not decode is logged and dropped."""
        self._endpoint_token(EntityKind.SUBSCRIPTION, topic, ros_type, qos or Qos())
        key = topic_key(self.context.domain_id, topic, ros_type, _messages.type_hash(ros_type))

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                message = _messages.decode(ros_type, sample.payload.to_bytes())
                raw = sample.attachment
                attachment = None if raw is None else decode_attachment(raw.to_bytes())
            except Exception as exc:  # a foreign peer's bad bytes must not stop the node
                log.warning("%s: dropped a sample that is not a %s: %s", topic, ros_type, exc)
                return
            on_message(message, attachment)

        loop = LoopHandle()
        subscriber = self.context.session.declare_subscriber(key, loop.forward(on_sample))
        self._undeclare.append(subscriber)

    def close(self) -> None:
        """Undeclare every token, publisher and subscriber of the node (newest first)."""
        while self._undeclare:
            undeclare(self._undeclare.pop())  # a no-op once the session closed


class Publisher:
    """Puts payloads with rmw_zenoh's attachment; :attr:`sequence` counts from 1."""

    def __init__(self, zenoh_publisher: zenoh.Publisher, gid: bytes, key: str) -> None:
        self.zenoh_publisher = zenoh_publisher
        self.gid = gid
        self.key = key
        self.sequence = 0

    def publish(self, payload: bytes) -> None:
        self.sequence += 1
        attachment = Attachment(self.sequence, time.time_ns(), self.gid)
        self.zenoh_publisher.put(payload, attachment=encode_attachment(attachment))
