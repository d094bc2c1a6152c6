"""What the robot knows: topic readers that write to the blackboard, and guest conditions.

The readers follow py_trees_ros's "to blackboard" idiom: a subscription callback only keeps the
latest message (it runs in the executor, not in the tick); the tick converts it and writes the
output ports, so the blackboard changes only while the tree ticks. Placed in a Topics2BB
sequence at the front of the tree they return SUCCESS once data has arrived, and RUNNING
before it, so the tree waits for the simulator.

The RFID reader is the exception: the sensor publishes NOTHING while nobody is in range, so
silence is a reading in itself. The last list is trusted for ``stale_after`` sim seconds and
replaced by an empty one afterwards; before any message the list is empty as well, and the
reader always returns SUCCESS.

:class:`GuestInRange` and :class:`GuestFollowing` read those ports: the first is a plain
condition, the second a monitor that runs beside navigation while guiding, remembers where
the robot was when it last had the guest in range, and fails once the guest has been out of
range for longer than its ``grace`` period. All times are sim time.
"""

import math
from typing import Any, ClassVar

from nav_msgs.msg import OccupancyGrid
from py_trees.ports import PortInformation
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from servicesim_competition.msg import ActorNames

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.people import Costmap2D
from bt_servicesim.ros.shared_subscription import shared_subscription
from bt_servicesim.ros.sim_clock import node_from_setup_kwargs, sim_now_s

__all__ = [
    "CostmapToBlackboard",
    "MapToBlackboard",
    "RfidToBlackboard",
]


NEVER = math.inf
"""The ``rfid_age`` before the first RFID message."""

MAP_QOS = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""The map is latched: published once, kept for late joiners."""


class _TopicReader(ActionNode, register=False):
    """Keep the latest message of one topic; subclasses write it to their ports.

    Args:
        name: the behaviour's name
        topic: the topic to subscribe to
    """

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = {}
    MESSAGE_TYPE: ClassVar[type]
    QOS: ClassVar[QoSProfile | int] = qos_profile_sensor_data

    def __init__(self, name: str, topic: str, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.topic = topic
        self.node: Node | None = None
        self._message: Any = None
        self._received_s = 0.0

    def setup(self, **kwargs: Any) -> None:
        """Subscribe on ``kwargs["node"]``, sharing its subscription to the topic if it has one
        (:mod:`bt_servicesim.ros.shared_subscription`); only the newest of a burst is decoded."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        shared_subscription(self.node, self.MESSAGE_TYPE, self.topic, self._on_message, self.QOS,
                            latest_only=True)

    def initialise(self) -> None:
        """Nothing to start: the subscription runs from setup onwards."""
        self._require_node()
        self.feedback_message = f"reading {self.topic}"

    def _on_message(self, message: Any) -> None:
        self._received_s = sim_now_s(self._require_node().get_clock())
        self._message = message

    def _require_node(self) -> Node:
        if self.node is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        return self.node

    def _waiting(self) -> Status:
        self.feedback_message = f"waiting for the first message on {self.topic}"
        return Status.RUNNING


class RfidToBlackboard(_TopicReader):
    """The people in RFID range (``actors_in_range``) and the reading's age (``rfid_age``).

    Args:
        name: the behaviour's name
        topic: the RFID topic
        stale_after: sim seconds after the last message from which nobody is in range
    """

    MESSAGE_TYPE = ActorNames
    OUTPUT_PORTS: Ports = {
        "actors_in_range": PortInformation(data_type=list[str], required=False),
        "rfid_age": PortInformation(data_type=float, required=False),
    }

    def __init__(
        self,
        name: str = "RfidToBlackboard",
        topic: str = "/servicebot/rfid",
        stale_after: float = 2.0,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, topic=topic, **kwargs)
        self.stale_after = float(stale_after)
        self._names: tuple[object, list[str]] = (None, [])

    def update(self) -> Status:
        """Write the list, emptied once it is stale; always SUCCESS."""
        message, received_s = self._message, self._received_s
        if message is None:
            self._write([], NEVER)
            self.feedback_message = "no RFID message yet: nobody in range"
            return Status.SUCCESS
        age = max(0.0, sim_now_s(self._require_node().get_clock()) - received_s)
        if age > self.stale_after:
            self._write([], age)
            self.feedback_message = f"RFID silent for {age:.1f} sim s: nobody in range"
            return Status.SUCCESS
        if self._names[0] is not message:  # one list per message: the tree log compares
            self._names = (message, [str(name) for name in message.actor_names])  # by identity
        names = self._names[1]
        self._write(names, age)
        self.feedback_message = f"in range: {', '.join(names) or 'nobody'}"
        return Status.SUCCESS

    def _write(self, names: list[str], age: float) -> None:
        self._set_output("actors_in_range", names)
        self._set_output("rfid_age", float(age))


class MapToBlackboard(_TopicReader):
    """The static map (``occupancy``, an ``OccupancyGrid2D``); RUNNING until it arrives.

    The conversion runs once per map message, in the callback, so ticks stay cheap.

    Args:
        name: the behaviour's name
        topic: the map topic (latched)
    """

    MESSAGE_TYPE = OccupancyGrid
    QOS = MAP_QOS
    OUTPUT_PORTS: Ports = {
        "occupancy": PortInformation(data_type=OccupancyGrid2D, required=False),
    }

    def __init__(
        self, name: str = "MapToBlackboard", topic: str = "/servicebot/map", **kwargs: Any
    ) -> None:
        super().__init__(name=name, topic=topic, **kwargs)
        self._written: object = None

    def _on_message(self, message: Any) -> None:
        self._received_s = sim_now_s(self._require_node().get_clock())
        self._message = OccupancyGrid2D.from_message(message)

    def update(self) -> Status:
        """Write the map when a new one has arrived."""
        occupancy = self._message
        if occupancy is None:
            return self._waiting()
        if occupancy is not self._written:
            self._set_output("occupancy", occupancy)
            self._written = occupancy
        self.feedback_message = f"map from {self.topic} on the blackboard"
        return Status.SUCCESS


class CostmapToBlackboard(_TopicReader):
    """Navigation's costmap (``costmap``, a :class:`~bt_servicesim.planning.people.Costmap2D`),
    where the lidar marked the people near the robot; always SUCCESS.

    Nav2 publishes its global costmap about once a second; the tree does not wait for it: until
    the first arrives the port stays unset, and whoever reads it does without. A message that
    is no costmap (its size does not match its data) or lies in another frame than
    ``global_frame`` (a local costmap in ``odom``) is left out, with a warning the first time.

    Args:
        name: the behaviour's name
        topic: the costmap topic
        global_frame: the frame the costmap must be in, the map's
    """

    MESSAGE_TYPE = OccupancyGrid
    QOS = MAP_QOS
    OUTPUT_PORTS: Ports = {
        "costmap": PortInformation(data_type=Costmap2D, required=False),
    }

    def __init__(self, name: str = "CostmapToBlackboard",
                 topic: str = "/servicebot/global_costmap/costmap", global_frame: str = "map",
                 **kwargs: Any) -> None:
        super().__init__(name=name, topic=topic, **kwargs)
        self.global_frame = global_frame
        self._written: object = None
        self._refused = ""

    def _on_message(self, message: Any) -> None:
        try:
            if message.header.frame_id != self.global_frame:
                raise ValueError(f"a costmap in frame {message.header.frame_id!r}, "
                                 f"not {self.global_frame!r}")
            costmap = Costmap2D.from_message(message)
        except ValueError as error:
            if str(error) != self._refused:
                self._refused = str(error)
                self._require_node().get_logger().warning(f"{self.topic}: left out: {error}")
            return
        self._received_s = sim_now_s(self._require_node().get_clock())
        self._message = costmap

    def update(self) -> Status:
        """Write the costmap when a new one has arrived."""
        costmap = self._message
        if costmap is None:
            self.feedback_message = f"no costmap on {self.topic} yet"
            return Status.SUCCESS
        if costmap is not self._written:
            self._set_output("costmap", costmap)
            self._written = costmap
        self.feedback_message = f"costmap of {costmap.stamp_s:.1f} s on the blackboard"
        return Status.SUCCESS


# ------------------------------------------------------------------------- the guest




