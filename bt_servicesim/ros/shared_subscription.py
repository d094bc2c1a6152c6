"""One subscription per topic in a node, handed to every reader of that topic.

The executive's node reads several topics more than once: the tree's topic readers, the
referee monitor and the run's MCAP recorder all want odometry, RFID or the referee's state.
rclpy's executor runs one handler per subscription per message, each after a pass over the
node's wait set, and at 50 times real time that per-message work is most of what keeps the
executive from ticking on time. So readers in one node share a subscription per topic
(:func:`shared_subscription`):

* it takes messages serialised and deserialises each at most once, only when some reader
  wants messages rather than bytes (the recorder writes the bytes DDS delivered);
* each wake-up takes every message waiting, oldest first, and hands each to every reader in
  the order they subscribed: one handler per burst rather than one per message and reader.
  In lockstep the node holds a burst and hands it on message by message when the tick is
  due (:mod:`bt_servicesim.ros.traffic`): the queue then holds the next period's messages,
  which are not taken here;
  A reader that only keeps the latest message (``latest_only``) gets the newest of a burst
  alone, and nothing is decoded for the others;
* the subscription has the first reader's QoS. A later reader shares it only if it has the
  same reliability and at least the durability (transient local over volatile) and history
  depth the reader asked for; otherwise the reader gets a subscription of its own.
  Reliability must match, not merely be "at least": a reliable reader does not match a
  best-effort publisher, so a best-effort reader (the tree's sensor readers ask for
  ``qos_profile_sensor_data``) on a reliable subscription would hear nothing from a backend
  that publishes best effort, and a reliable reader on a best-effort one could lose messages.
  In lockstep the node makes every subscription reliable
  (:class:`~bt_servicesim.ros.node.ExecutiveNode`), so there a best-effort request is matched
  as the reliable one it becomes;
* a transient-local (latched) subscription keeps the last messages its history holds and
  hands them to a latched reader that joins later, at once, as DDS would have given a
  subscription of its own: the map, published once, reaches the tree's reader however late
  it subscribes. A volatile reader gets only what arrives after it joined.

Readers given messages share the same message object, so none may change it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

from rclpy.exceptions import InvalidHandle
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

from bt_servicesim.ros.lockstep import LockstepHost
from bt_servicesim.ros.node import ExecutiveNode, reliable

__all__ = ["Reader", "SharedSubscription", "queued_raw_messages", "shared_subscription"]

_REGISTRY_ATTRIBUTE = "_bt_servicesim_shared_subscriptions"


class Reader:
    """One reader's place on a shared subscription; :meth:`cancel` leaves it."""

    def __init__(self, shared: SharedSubscription, callback: Callable[[Any], None], *,
                 raw: bool, latest_only: bool) -> None:
        self.shared = shared
        self.callback = callback
        self.raw = raw
        self.latest_only = latest_only

    def cancel(self) -> None:
        """Stop reading; the subscription goes once its last reader has."""
        self.shared.remove(self)


class SharedSubscription:
    """A raw subscription that hands every message to its readers (see module docstring)."""

    def __init__(self, node: Node, message_type: type, topic: str, qos: QoSProfile) -> None:
        self.node = node
        self.message_type = message_type
        self.topic = topic
        self.qos = qos
        self.readers: list[Reader] = []
        self._traffic = node.traffic if isinstance(node, LockstepHost) else None
        """What the node counts, if it does: a held subscription's queue is left to it."""
        latched = qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        self._kept: deque[bytes] | None = deque(maxlen=max(qos.depth, 1)) if latched else None
        self.subscription: Subscription[Any] | None = node.create_subscription(
            message_type, topic, self._on_data, qos, raw=True)

    def covers(self, qos: QoSProfile) -> bool:
        """Whether this subscription hears the publishers ``qos`` would (the same reliability)
        and keeps at least what it asks for (durability and history)."""
        have, want = self.qos, qos
        same_reliability = have.reliability == want.reliability
        durable = (have.durability == DurabilityPolicy.TRANSIENT_LOCAL
                   or want.durability != DurabilityPolicy.TRANSIENT_LOCAL)
        deep = have.history == HistoryPolicy.KEEP_ALL or (
            want.history != HistoryPolicy.KEEP_ALL and have.depth >= want.depth)
        return same_reliability and durable and deep

    def add(self, callback: Callable[[Any], None], *, raw: bool, latest_only: bool,
            latched: bool) -> Reader:
        """A new reader; a ``latched`` one gets the kept messages before this returns."""
        reader = Reader(self, callback, raw=raw, latest_only=latest_only)
        self.readers.append(reader)
        kept = list(self._kept or ()) if latched else []
        for data in kept[-1:] if latest_only else kept:
            callback(data if raw else deserialize_message(data, self.message_type))
        return reader

    def remove(self, reader: Reader) -> None:
        if reader in self.readers:
            self.readers.remove(reader)
        if not self.readers and self.subscription is not None:
            self.node.destroy_subscription(self.subscription)
            self.subscription = None
            siblings = _registry(self.node).get((self.topic, self.message_type), [])
            if self in siblings:
                siblings.remove(self)

    def _on_data(self, data: bytes) -> None:
        burst = [data]
        traffic = self._traffic
        if self.subscription is not None and not (traffic is not None
                                                  and traffic.holds(self.subscription)):
            burst.extend(queued_raw_messages(self.subscription))
            if traffic is not None and len(burst) > 1:  # taken here, past the node's count
                traffic.took_more(self.subscription, len(burst) - 1)
        if self._kept is not None:
            self._kept.extend(burst)
        newest = len(burst) - 1
        for index, taken in enumerate(burst):
            message: object | None = None
            for reader in list(self.readers):
                if reader.latest_only and index != newest:
                    continue
                if reader.raw:
                    reader.callback(taken)
                    continue
                if message is None:
                    message = deserialize_message(taken, self.message_type)
                reader.callback(message)


def shared_subscription(node: Node, message_type: type, topic: str,
                        callback: Callable[[Any], None], qos: QoSProfile | int, *,
                        raw: bool = False, latest_only: bool = False) -> Reader:
    """Read ``topic`` through the node's shared subscription (made on first use).

    ``callback`` gets each message (serialised bytes with ``raw=True``), or with
    ``latest_only=True`` the newest of each burst that arrived together.
    """
    profile = _requested_on(node, qos)
    latched = profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    shared_list = _registry(node).setdefault((topic, message_type), [])
    for shared in shared_list:
        if shared.covers(profile):
            return shared.add(callback, raw=raw, latest_only=latest_only, latched=latched)
    shared = SharedSubscription(node, message_type, topic, profile)
    shared_list.append(shared)
    return shared.add(callback, raw=raw, latest_only=latest_only, latched=latched)


def queued_raw_messages(subscription: Subscription[Any]) -> Iterator[bytes]:
    """Take the messages waiting in a raw subscription's queue, oldest first, until none is."""
    while True:
        try:
            with subscription.handle:  # None once the queue is empty (rclpy's stub omits it)
                taken: tuple[bytes, Any] | None = subscription.handle.take_message(
                    subscription.msg_type, True)
        except InvalidHandle:
            return
        if taken is None:
            return
        yield taken[0]


def _requested_on(node: Node, qos: QoSProfile | int) -> QoSProfile:
    """``qos`` as a subscription of ``node`` gets it: in lockstep, reliable
    (:attr:`~bt_servicesim.ros.node.ExecutiveNode.reliable_subscriptions`)."""
    if isinstance(node, ExecutiveNode) and node.reliable_subscriptions:
        qos = reliable(qos)
    return qos if isinstance(qos, QoSProfile) else QoSProfile(depth=qos)


def _registry(node: Node) -> dict[tuple[str, type], list[SharedSubscription]]:
    """The node's shared subscriptions, kept on the node so they live and die with it."""
    registry = getattr(node, _REGISTRY_ATTRIBUTE, None)
    if registry is None:
        registry = {}
        setattr(node, _REGISTRY_ATTRIBUTE, registry)
    return registry
