"""What a node has sent and received, counted where it passes through the node.

Lockstep (:mod:`bt_servicesim.ros.lockstep`) needs to know, before each tick, whether everything
the simulator sent has arrived, and to tell the simulator, after it, how many requests the
tick (and the callbacks since the last one) sent. Counting happens at the node's own doors,
so no behaviour changes for it: :class:`~bt_servicesim.ros.node.ExecutiveNode` wraps every
subscription callback, every service client's ``call_async``, every publisher's ``publish``
and every action client's goal, cancel and result requests and its feedback.

Endpoints are named as the simulator names them: a service by its name, an action by its
name followed by ``:goal``, ``:cancel``, ``:result`` or ``:feedback``; a topic the node
publishes by the topic's name. A request's answer is counted when its future completes.
The lockstep protocol's own topics and service are never counted.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["PROTOCOL_PREFIX", "Traffic", "endpoint_name"]

PROTOCOL_PREFIX = "/servicesim/lockstep/"


def endpoint_name(name: str) -> str:
    """A service, action or topic name as the simulator counts it: absolute."""
    return name if name.startswith("/") else f"/{name}"


class Traffic:
    """Counts per topic and endpoint; ``on_arrival`` is told of everything that arrives."""

    def __init__(self) -> None:
        self.received: dict[int, int] = {}
        """Messages taken per reader (a subscription, by :meth:`reader` key)."""
        self.readers: dict[int, Any] = {}
        """The subscriptions by key; a destroyed one is forgotten."""
        self.sent: dict[str, int] = {}
        """Requests sent per endpoint, and messages published per topic."""
        self.answered: dict[str, int] = {}
        """Answers (replies, results, feedback) received per endpoint."""
        self.endpoints: set[str] = set()
        """The endpoints this node has a client for."""
        self.on_arrival: Callable[[], None] | None = None

    def _arrived(self, table: dict[Any, int], name: Any) -> None:
        table[name] = table.get(name, 0) + 1
        if self.on_arrival is not None:
            self.on_arrival()

    def counted_callback(self, topic: str,
                         callback: Callable[..., Any]) -> tuple[int | None, Callable[..., Any]]:
        """A key for a new reader of ``topic`` and ``callback`` counting each message for it.

        Each subscription counts for itself: two on one topic (different QoS) each receive
        every message. The key is None for the protocol's own topics (not counted).
        """
        if topic.startswith(PROTOCOL_PREFIX):
            return None, callback
        key = len(self.received)  # never shrinks: keys are unique
        self.received[key] = 0

        def receive(*args: Any) -> Any:
            try:
                return callback(*args)
            finally:
                self._arrived(self.received, key)

        return key, receive

    def add_reader(self, key: int | None, subscription: Any) -> None:
        if key is not None:
            self.readers[key] = subscription

    def forget(self, subscription: Any) -> None:
        """A destroyed subscription: nothing more is expected of it."""
        for key, reader in list(self.readers.items()):
            if reader is subscription:
                del self.readers[key]

    def took_more(self, subscription: Any, count: int) -> None:
        """``count`` more messages taken by a callback from its own subscription's queue."""
        for key, reader in self.readers.items():
            if reader is subscription:
                self.received[key] += count

    def watch_publisher(self, publisher: Any) -> None:
        topic = publisher.topic_name
        if topic.startswith(PROTOCOL_PREFIX):
            return
        publish = publisher.publish

        def counted_publish(message: Any) -> None:
            publish(message)
            self.sent[topic] = self.sent.get(topic, 0) + 1

        publisher.publish = counted_publish

    def watch_client(self, client: Any) -> None:
        """Count a service client's requests and replies."""
        endpoint = endpoint_name(client.srv_name)
        if endpoint.startswith(PROTOCOL_PREFIX):
            return
        self.endpoints.add(endpoint)
        client.call_async = self._counting(endpoint, client.call_async)

    def watch_action_client(self, client: Any) -> None:
        """Count an action client's goal, cancel and result requests, answers and feedback."""
        action = endpoint_name(client._action_name)
        self.endpoints.update(f"{action}:{kind}" for kind in
                              ("goal", "cancel", "result", "feedback"))
        client._cancel_goal_async = self._counting(f"{action}:cancel",
                                                   client._cancel_goal_async)
        client._get_result_async = self._counting(f"{action}:result", client._get_result_async)
        send_goal = self._counting(f"{action}:goal", client.send_goal_async)

        def send_goal_async(goal: Any, feedback_callback: Callable[[Any], None] | None = None,
                            goal_uuid: Any = None) -> Any:
            def on_feedback(message: Any) -> None:
                try:
                    if feedback_callback is not None:
                        feedback_callback(message)
                finally:
                    self._arrived(self.answered, f"{action}:feedback")

            return send_goal(goal, feedback_callback=on_feedback, goal_uuid=goal_uuid)

        client.send_goal_async = send_goal_async

    def _counting(self, endpoint: str, send: Callable[..., Any]) -> Callable[..., Any]:
        def counted(*args: Any, **kwargs: Any) -> Any:
            future = send(*args, **kwargs)
            self.sent[endpoint] = self.sent.get(endpoint, 0) + 1
            future.add_done_callback(lambda _: self._arrived(self.answered, endpoint))
            return future

        return counted
