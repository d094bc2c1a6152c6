"""The executive's ROS node: on sim time, and cheap to spin.

A run spins one node for everything on the executive's side: the tree's behaviours, the
referee monitor and the run's records. Every entity of that node is one more DDS endpoint and
one more thing the executor looks after -- rclpy's Python executors rebuild their wait set
from all of them each time they wait, which is thousands of times a wall second when the
simulator runs 50 times faster than real time (the run itself uses the ``EventsExecutor``,
:mod:`bt_servicesim.mission.run`). So the node leaves out what nobody uses on it:

* the parameter and type-description services (the executive's one parameter,
  ``use_sim_time``, is set here and never changed from outside);
* the default QoS-event handlers rclpy gives each subscription and publisher (two waitables
  each, about forty on the mission tree's node); mismatched QoS still shows in
  ``ros2 topic info --verbose``, and an explicit ``event_callbacks`` argument is kept;
* nothing of lockstep's bookkeeping in the behaviours: the node counts what passes its doors
  (:mod:`bt_servicesim.ros.traffic`: messages per subscription, requests and answers per
  endpoint, messages per published topic) for :mod:`bt_servicesim.ros.lockstep`, and in
  lockstep makes a subscription asked for best effort reliable (``reliable_subscriptions``),
  since a count needs every message, and every subscription keeps at least two periods'
  messages (:data:`MIN_READER_DEPTH`);
* duplicate clients: behaviours that call the same service or the same action share one
  client per node (:func:`shared_client`, :func:`shared_action_client`). A client serves any
  number of requests or goals at once, each with its own future, so sharing changes nothing
  for a behaviour but the number of DDS endpoints and wait-set entries.

The ``EventsExecutor`` has two known crashes in the Kilted wheels, and the node keeps clear of
both. A callback that raises takes the whole process down with a segmentation fault
(ros2/rclpy#1641, fixed upstream later): so every subscription and timer callback made on this
node runs guarded (:meth:`ExecutiveNode.guarded`); what it raised is kept in
:attr:`ExecutiveNode.callback_error` for the run to fail the mission with, and the process goes
on. Destroying publishers or subscriptions that carry QoS-event callbacks while discovery
churns crashes it too (ros2/rclpy#1644): this node gives none of its entities event callbacks
unless asked to (``tests/ros/test_events_executor_safety.py`` runs both cases). The guard (a
Python call and a ``try``) is a small fraction of what the ``EventsExecutor`` takes per message,
which is itself a fraction of what rclpy's Python executor takes, crashes and all
(docs/reference/performance.md).
"""

from __future__ import annotations

import copy
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from rclpy.action import ActionClient
from rclpy.client import Client
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from rclpy.type_support import MsgT
from rclpy.waitable import Waitable

from bt_servicesim.ros.traffic import Traffic

if TYPE_CHECKING:
    from bt_servicesim.ros.lockstep import LockstepClient

__all__ = ["ExecutiveNode", "shared_action_client", "shared_client"]

_CLIENTS_ATTRIBUTE = "_bt_servicesim_shared_clients"


class ExecutiveNode(Node):
    """A node on sim time without parameter services or default QoS-event handlers."""

    def __init__(self, name: str = "bt_servicesim_executive", *, use_sim_time: bool = True,
                 **kwargs: Any) -> None:
        overrides = [
            Parameter("use_sim_time", Parameter.Type.BOOL, use_sim_time),
            Parameter("start_type_description_service", Parameter.Type.BOOL, False),
        ]
        self.traffic = Traffic()
        """What the node sent and received, for lockstep (:mod:`bt_servicesim.ros.traffic`)."""
        self.reliable_subscriptions = False
        """Whether subscriptions asked for best effort get reliable ones: set in lockstep,
        whose backend publishes reliably and whose counts need every message."""
        self.lockstep: LockstepClient | None = None
        """The :class:`~bt_servicesim.ros.lockstep.LockstepClient` once joined, else None."""
        super().__init__(name, start_parameter_services=False,
                         parameter_overrides=overrides, **kwargs)
        self.callback_error: str | None = None
        """The first exception a guarded callback raised, as one line; None while none did."""
        self.callback_traceback: str | None = None

    def guarded(self, callback: Callable[..., None]) -> Callable[..., None]:
        """``callback``, but an exception it raises is kept (the first) instead of escaping."""
        def call(*args: object) -> None:
            try:
                callback(*args)
            except Exception as error:  # anything escaping kills the process: keep it instead
                if (stop := stop_behind(error)) is not None:
                    raise stop from error
                self.note_error(error, where=getattr(callback, "__qualname__", repr(callback)))

        return call

    def note_error(self, error: BaseException, *, where: str) -> None:
        """Keep the first error a callback or a tick raised, with its traceback."""
        if self.callback_error is None:
            text = " ".join(str(error).split())
            self.callback_error = f"{type(error).__name__} in {where}: {text}"
            self.callback_traceback = "".join(traceback.format_exception(error))

    def destroy_node(self) -> None:
        """Destroy the shared action clients too: rclpy's ``destroy_node`` leaves waitables
        alive, and an action client keeps the node, its context and its DDS participant (with a
        shared-memory segment in /dev/shm) alive until the process ends, sometimes for good."""
        shared = _clients_of(self)
        for client in shared.actions.values():
            client.destroy()
        shared.services.clear()
        shared.actions.clear()
        super().destroy_node()

    def create_subscription(self, msg_type: type[MsgT], topic: str,
                            callback: Callable[..., None], qos_profile: QoSProfile | int,
                            **kwargs: Any) -> Subscription[MsgT]:
        kwargs.setdefault("event_callbacks",
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        qos_profile = deep_enough(qos_profile)
        if self.reliable_subscriptions:
            qos_profile = reliable(qos_profile)
        # counted around the guard: a message whose reader raised has still arrived
        key, counted = self.traffic.counted_callback(self.resolve_topic_name(topic),
                                                     self.guarded(callback))
        subscription = super().create_subscription(msg_type, topic, counted, qos_profile,
                                                   **kwargs)
        self.traffic.add_reader(key, subscription)
        return subscription

    def destroy_subscription(self, subscription: Subscription[Any]) -> bool:
        self.traffic.forget(subscription)
        return super().destroy_subscription(subscription)

    def create_client(self, *args: Any, **kwargs: Any) -> Client[Any, Any]:
        client: Client[Any, Any] = super().create_client(*args, **kwargs)
        self.traffic.watch_client(client)
        return client

    def add_waitable(self, waitable: Waitable[Any]) -> None:
        if isinstance(waitable, ActionClient):
            self.traffic.watch_action_client(waitable)
        super().add_waitable(waitable)

    def create_timer(self, timer_period_sec: float, callback: Callable[..., None] | None,
                     *args: Any, **kwargs: Any) -> Timer:
        guarded = None if callback is None else self.guarded(callback)
        return super().create_timer(timer_period_sec, guarded, *args, **kwargs)

    def create_publisher(self, *args: Any, **kwargs: Any) -> Publisher[Any]:
        kwargs.setdefault("event_callbacks", PublisherEventCallbacks(use_default_callbacks=False))
        publisher = super().create_publisher(*args, **kwargs)
        self.traffic.watch_publisher(publisher)
        return publisher


def stop_behind(error: BaseException) -> BaseException | None:
    """The stop signal that caused ``error``, if one did.

    A signal's exception (``KeyboardInterrupt``, or any ``BaseException`` that is not an
    ``Exception``) raised while rclpy's C++ runs Python code -- a message's field setter while
    it converts a message it took -- comes out of the call as pybind11's ``TypeError`` ("Unable
    to convert function return value"), with the stop as its cause. That is the stop, not a bug.
    """
    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        seen.add(id(cause))
        if not isinstance(cause, Exception):
            return cause
        cause = cause.__cause__ or cause.__context__
    return None


MIN_READER_DEPTH = 10
"""The fewest messages a subscription of this node keeps: in lockstep the simulator publishes
its next period while the node is still taking the last one's (docs/reference/simulator.md,
"Lockstep"), so a reader must keep two periods' worth (the referee's score comes five times
a period) or lose one, and lockstep counts every message. A latched reader's usual depth is one."""


def deep_enough(qos: QoSProfile | int) -> QoSProfile | int:
    """``qos`` keeping at least :data:`MIN_READER_DEPTH` messages if it is reliable (lockstep
    counts only reliable readers; best effort ones, such as rclpy's own /clock reader, and
    KEEP_ALL are left as they are)."""
    if isinstance(qos, int):
        return max(qos, MIN_READER_DEPTH)
    if (qos.history == HistoryPolicy.KEEP_ALL or qos.depth >= MIN_READER_DEPTH
            or qos.reliability != ReliabilityPolicy.RELIABLE):
        return qos
    deeper = copy.copy(qos)
    deeper.depth = MIN_READER_DEPTH
    return deeper


def reliable(qos: QoSProfile | int) -> QoSProfile | int:
    """``qos``, reliable and at least 10 deep if it was best effort (depth alone: as it is)."""
    if isinstance(qos, int) or qos.reliability != ReliabilityPolicy.BEST_EFFORT:
        return qos
    return QoSProfile(history=qos.history, depth=max(qos.depth, 10),
                      reliability=ReliabilityPolicy.RELIABLE, durability=qos.durability)


def shared_client(node: Node, service_type: type, service: str) -> Client[Any, Any]:
    """The node's one client for ``service``, created on first use."""
    clients = _clients_of(node).services
    key = (service_type, service)
    if key not in clients:
        clients[key] = node.create_client(service_type, service)
    return clients[key]


def shared_action_client(node: Node, action_type: type,
                         action: str) -> ActionClient[Any, Any, Any]:
    """The node's one action client for ``action``, created on first use."""
    clients = _clients_of(node).actions
    key = (action_type, action)
    if key not in clients:
        clients[key] = ActionClient(node, action_type, action)
    return clients[key]


@dataclass
class _SharedClients:
    """A node's shared clients, by interface type and name."""

    services: dict[tuple[type, str], Client[Any, Any]] = field(default_factory=dict)
    actions: dict[tuple[type, str], ActionClient[Any, Any, Any]] = field(default_factory=dict)


def _clients_of(node: Node) -> _SharedClients:
    """The node's shared clients, kept on the node so they live and die with it."""
    clients = getattr(node, _CLIENTS_ATTRIBUTE, None)
    if not isinstance(clients, _SharedClients):
        clients = _SharedClients()
        setattr(node, _CLIENTS_ATTRIBUTE, clients)
    return clients
