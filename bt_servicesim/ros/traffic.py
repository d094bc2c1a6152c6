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

*Holding* (:meth:`Traffic.hold`, in lockstep; why: docs/reference/simulator.md, "The
pipeline"): what arrives is counted on arrival but handed on only by :meth:`Traffic.release`,
up to the counts of the period about to be ticked: the message to the reader's callback, the
answer to the future the request's caller holds (a future of its own, completed on release,
not rclpy's), the feedback to the goal's feedback callback. A held reader's arrival also takes
whatever else waits in the subscription's queue, so a burst costs one wake-up.
:meth:`Traffic.stop_holding` hands on everything still held.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import Any, TypeVar

from rclpy.exceptions import InvalidHandle
from rclpy.subscription import Subscription
from rclpy.task import Future

__all__ = ["PROTOCOL_PREFIX", "Traffic", "endpoint_name"]

PROTOCOL_PREFIX = "/servicesim/lockstep/"
Name = TypeVar("Name", int, str)
"""A reader's key or an endpoint's name."""


def endpoint_name(name: str) -> str:
    """A service, action or topic name as the simulator counts it: absolute."""
    return name if name.startswith("/") else f"/{name}"


class Traffic:
    """Counts per topic and endpoint; ``on_arrival`` is told of everything that arrives."""

    def __init__(self) -> None:
        self.received: dict[int, int] = {}
        """Messages taken per reader (a subscription, by :meth:`reader` key)."""
        self.readers: dict[int, Subscription[Any]] = {}
        """The subscriptions by key; a destroyed one is forgotten."""
        self.sent: dict[str, int] = {}
        """Requests sent per endpoint, and messages published per topic."""
        self.answered: dict[str, int] = {}
        """Answers (replies, results, feedback) received per endpoint."""
        self.endpoints: set[str] = set()
        """The endpoints this node has a client for."""
        self.on_arrival: Callable[[], None] | None = None
        self.arrivals = 0
        """Messages and answers arrived in all: a cheap sign that something did."""
        self.delivered: dict[int, int] = {}
        """Messages handed to each reader's callback (arrived and, if held, released)."""
        self.answers_delivered: dict[str, int] = {}
        """Answers handed on per endpoint (arrived and, if held, released)."""
        self.holding = False
        self._held_readers: set[int] = set()
        self._held_subscriptions: set[int] = set()
        self._held_endpoints: set[str] = set()
        self._held_messages: dict[int, deque[tuple[object, ...]]] = {}
        self._held_answers: dict[str, deque[Callable[[], None]]] = {}
        self._callbacks: dict[int, Callable[..., None]] = {}

    def _arrived(self, table: dict[Name, int], name: Name) -> None:
        table[name] = table.get(name, 0) + 1
        self.arrivals += 1
        if self.on_arrival is not None:
            self.on_arrival()

    def counted_callback(self, topic: str,
                         callback: Callable[..., None]) -> tuple[int | None, Callable[..., None]]:
        """A key for a new reader of ``topic`` and ``callback`` counting each message for it.

        Each subscription counts for itself: two on one topic (different QoS) each receive
        every message. The key is None for the protocol's own topics (not counted).
        """
        if topic.startswith(PROTOCOL_PREFIX):
            return None, callback
        key = len(self.received)  # never shrinks: keys are unique
        self.received[key] = 0
        self.delivered[key] = 0
        self._callbacks[key] = callback

        def receive(*args: object) -> None:
            if self.holding and key in self._held_readers:
                self._hold_message(key, args)
                return
            try:
                callback(*args)
            finally:
                self.delivered[key] += 1
                self._arrived(self.received, key)

        return key, receive

    # --------------------------------------------------------------- holding
    def hold(self, readers: set[int], endpoints: set[str]) -> None:
        """Hold from now on what arrives for ``readers`` and every answer and feedback on
        ``endpoints``."""
        self._held_endpoints = set(endpoints)
        self._held_readers = set(readers)
        self._held_subscriptions = {id(self.readers[key]) for key in readers
                                    if key in self.readers}
        self.holding = True

    def hold_reader(self, key: int) -> None:
        """Hold what arrives for reader ``key`` too, from now on (a subscription the lockstep
        client counts from a later period than the join)."""
        self._held_readers.add(key)
        if key in self.readers:
            self._held_subscriptions.add(id(self.readers[key]))

    def stop_holding(self) -> None:
        """Hand on everything held, and hold nothing more."""
        self.holding = False
        self.release({key: self.received[key] for key in self._held_messages},
                     {endpoint: self.answered.get(endpoint, 0)
                      for endpoint in self._held_answers})

    def holds(self, subscription: Subscription[Any]) -> bool:
        """Whether what arrives for ``subscription`` is held (its callback must not take more)."""
        return self.holding and id(subscription) in self._held_subscriptions

    def release(self, messages: dict[int, int], answers: dict[str, int]) -> None:
        """Hand on held messages until each reader has had ``messages[key]``, then held
        answers until each endpoint has had ``answers[endpoint]``; both in the order given."""
        for key, target in messages.items():
            held = self._held_messages.get(key)
            callback = self._callbacks[key]
            while held and self.delivered[key] < target:
                self.delivered[key] += 1
                callback(*held.popleft())
        for endpoint, target in answers.items():
            waiting = self._held_answers.get(endpoint)
            while waiting and self.answers_delivered.get(endpoint, 0) < target:
                self.answers_delivered[endpoint] = self.answers_delivered.get(endpoint, 0) + 1
                waiting.popleft()()

    def _hold_message(self, key: int, args: tuple[object, ...]) -> None:
        held = self._held_messages.setdefault(key, deque())
        held.append(args)
        subscription = self.readers.get(key)
        taken = 1
        if subscription is not None:
            for more in _waiting(subscription, message_only=len(args) == 1):
                held.append(more)
                taken += 1
        self.received[key] += taken
        self.arrivals += taken
        if self.on_arrival is not None:
            self.on_arrival()

    def _hold_answer(self, endpoint: str, hand_on: Callable[[], None]) -> None:
        if not (self.holding and endpoint in self._held_endpoints):
            self.answers_delivered[endpoint] = self.answers_delivered.get(endpoint, 0) + 1
            hand_on()
            self._arrived(self.answered, endpoint)
            return
        self._held_answers.setdefault(endpoint, deque()).append(hand_on)
        self._arrived(self.answered, endpoint)

    def add_reader(self, key: int | None, subscription: Subscription[Any]) -> None:
        if key is not None:
            self.readers[key] = subscription

    def forget(self, subscription: Subscription[Any]) -> None:
        """A destroyed subscription: nothing more is expected of it, nor handed on."""
        for key, reader in list(self.readers.items()):
            if reader is subscription:
                del self.readers[key]
                self._held_readers.discard(key)
                self._held_subscriptions.discard(id(subscription))
                self._held_messages.pop(key, None)

    def took_more(self, subscription: Subscription[Any], count: int) -> None:
        """``count`` more messages taken by a callback from its own subscription's queue."""
        for key, reader in self.readers.items():
            if reader is subscription:
                self.received[key] += count
                self.delivered[key] += count
                self.arrivals += count

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
                self._hold_answer(f"{action}:feedback", lambda: (
                    None if feedback_callback is None else feedback_callback(message)))

            return send_goal(goal, feedback_callback=on_feedback, goal_uuid=goal_uuid)

        client.send_goal_async = send_goal_async

    def _counting(self, endpoint: str, send: Callable[..., Any]) -> Callable[..., Any]:
        """``send``, counted; while holding, the caller gets a future of its own, completed
        when the answer is released."""
        def counted(*args: Any, **kwargs: Any) -> Any:
            future = send(*args, **kwargs)
            self.sent[endpoint] = self.sent.get(endpoint, 0) + 1
            if not (self.holding and endpoint in self._held_endpoints):
                future.add_done_callback(lambda _: self._hold_answer(endpoint, _nothing))
                return future
            handed: Future[Any] = Future()
            future.add_done_callback(
                lambda done: self._hold_answer(endpoint, lambda: _pass_on(done, handed)))
            return handed

        return counted


def _nothing() -> None:
    """An answer rclpy's own future hands on: nothing more to do."""


def _pass_on(done: Future[Any], handed: Future[Any]) -> None:
    """Complete ``handed`` as ``done`` completed (unless its holder withdrew it)."""
    if handed.done():
        return
    if done.cancelled():
        handed.cancel()
    elif (exception := done.exception()) is not None:
        handed.set_exception(exception)
    else:
        handed.set_result(done.result())


def _waiting(subscription: Subscription[Any], *, message_only: bool) -> list[tuple[object, ...]]:
    """The messages waiting in ``subscription``'s queue, oldest first, as callback arguments."""
    taken: list[tuple[object, ...]] = []
    while True:
        try:
            with subscription.handle:  # None once the queue is empty (rclpy's stub omits it)
                message_info: tuple[object, object] | None = subscription.handle.take_message(
                    subscription.msg_type, subscription.raw)
        except InvalidHandle:
            return taken
        if message_info is None:
            return taken
        taken.append((message_info[0],) if message_only else tuple(message_info))
