"""Whether the backend has discovered this node's readers: a probe on ``/clock``.

A writer sends only to the readers its participant has discovered. Until the simulator has
discovered a reader of the executive (a topic's, or the reader of a service's answers), what
it sends there is lost: an answer the referee gave looked like a timeout. The run used to
wait a fixed two wall seconds for this after its servers were ready, which most of the time
was two seconds of nothing, and on a starved machine could still be too short.

Discovery gives an order to wait on instead. A participant announces its readers one after
another on one reliable built-in channel (SEDP's subscriptions writer), and the remote
participant matches its writers with each reader as it takes that reader's announcement, in
the order they were sent. So once a reader made after all the others has had a message from
the backend, the backend has taken the announcements of all the earlier readers, and matched
its writers with them. :func:`await_backend_discovery` makes such a reader on ``/clock``
(every simulated backend publishes it: the simulator repeats it while it holds for a client,
Gazebo as it runs) and spins until it has a message, within a wall-time limit; then it
destroys it. A real robot publishes no ``/clock``: there the probe reads ``/tf``
(:data:`SYSTEM_CLOCK_PROBE`), which a robot's drivers and localisation keep publishing.
"""

from __future__ import annotations

import time

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from bt_servicesim.ros.spinning import Spinner

__all__ = ["CLOCK_TOPIC", "SIM_CLOCK_PROBE", "SYSTEM_CLOCK_PROBE", "await_backend_discovery"]

CLOCK_TOPIC = "/clock"
SIM_CLOCK_PROBE = (Clock, CLOCK_TOPIC)
"""The probe's message type and topic on a backend with sim time."""
SYSTEM_CLOCK_PROBE = (TFMessage, "/tf")
"""... and on one without (a real robot)."""
PROBE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
"""Best effort matches every writer's reliability; a repeated clock makes up for a loss."""
SPIN_S = 0.05
"""Wall seconds of one wait for the probe's message."""


def await_backend_discovery(node: Node, executor: Spinner, *, limit_s: float,
                            probe: tuple[type, str] = SIM_CLOCK_PROBE) -> bool:
    """Until the backend has matched every reader ``node`` has now (True), or ``limit_s``
    wall seconds passed (False): see the module docstring. Call it once every reader
    whose first messages matter exists; what is made later is not covered. ``probe``: the
    (message type, topic) the probe reads, one the backend keeps publishing."""
    heard: list[bool] = []
    message_type, topic = probe
    reader = node.create_subscription(message_type, topic, lambda _message: heard.append(True),
                                      PROBE_QOS)
    try:
        deadline = time.monotonic() + limit_s
        while not heard and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=SPIN_S)
    finally:
        node.destroy_subscription(reader)
    return bool(heard)
