"""The robot's map pose the way a ROS 2 robot gives it: localisation's map -> odom on ``/tf``
composed with the latest odometry.

Odometry is in frame ``odom``, zero where the robot started, and drifts; only localisation
(Nav2's AMCL, or the simulator's model of it) knows where ``odom`` lies in the map, and it says
so by broadcasting map -> odom on ``/tf``, moving it at each filter update. tf2 gives a robot its
map pose as map -> odom -> base, and so does this reader: between filter updates the pose follows
odometry at its own rate, which ``amcl_pose`` (published only at updates) would not. Odometry
is never taken for a map pose: before localisation has broadcast map -> odom there is no pose,
and the reader is RUNNING.

The topics and the frames are settings; the defaults are the conventional names. A TFMessage
carries any number of transforms from any number of broadcasters, so every message is looked
at, and only the newest global frame -> odometry frame transform is kept.
"""

from __future__ import annotations

from typing import Any

from nav_msgs.msg import Odometry
from py_trees.ports import PortInformation
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.geometry import Pose2D, compose
from bt_servicesim.ros.messages import pose_from_msg, pose_from_transform
from bt_servicesim.ros.planar_cdr import odometry_pose, transforms
from bt_servicesim.ros.shared_subscription import shared_subscription
from bt_servicesim.ros.sim_clock import node_from_setup_kwargs

TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
"""What tf2's TransformListener subscribes to /tf with."""


class LocalisedPoseToBlackboard(ActionNode):
    """The robot's pose in ``global_frame`` (``robot_pose``); RUNNING until localised.

    Args:
        name: the behaviour's name
        odom_topic: the odometry topic (``nav_msgs/Odometry``, in ``odom_frame``)
        tf_topic: the transforms topic
        global_frame: the map frame localisation broadcasts
        odom_frame: odometry's frame, the child of the transform from ``global_frame``
    """

    INPUT_PORTS: Ports = {}
    OUTPUT_PORTS: Ports = {
        "robot_pose": PortInformation(data_type=Pose2D, required=False),
    }

    def __init__(self, name: str = "LocalisedPoseToBlackboard", *,
                 odom_topic: str = "/servicebot/odom", tf_topic: str = "/tf",
                 global_frame: str = "map", odom_frame: str = "odom", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.odom_topic, self.tf_topic = odom_topic, tf_topic
        self.global_frame, self.odom_frame = global_frame, odom_frame
        self.node: Node | None = None
        self._odometry: Pose2D | None = None
        self._map_to_odom: Pose2D | None = None
        self._wrong_frame = ""

    def setup(self, **kwargs: Any) -> None:
        """Subscribe to odometry (newest of a burst) and to every transform message, both
        read from their bytes (:mod:`bt_servicesim.ros.planar_cdr`)."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        shared_subscription(self.node, Odometry, self.odom_topic, self._on_odometry,
                            qos_profile_sensor_data, latest_only=True, raw=True)
        shared_subscription(self.node, TFMessage, self.tf_topic, self._on_transforms, TF_QOS,
                            raw=True)

    def initialise(self) -> None:
        """Nothing to start: the subscriptions run from setup onwards."""
        if self.node is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        self.feedback_message = f"reading {self.tf_topic} and {self.odom_topic}"

    def _on_odometry(self, data: bytes) -> None:
        read = odometry_pose(data)
        if read is None:  # not plain little-endian CDR: rclpy reads any encoding
            message = deserialize_message(data, Odometry)
            read = message.header.frame_id, pose_from_msg(message.pose.pose)
        frame, pose = read
        if frame != self.odom_frame:
            self._wrong_frame = frame
            return
        self._odometry = pose

    def _on_transforms(self, data: bytes) -> None:
        read = transforms(data)
        if read is None:
            read = [(stamped.header.frame_id, stamped.child_frame_id,
                     pose_from_transform(stamped.transform))
                    for stamped in deserialize_message(data, TFMessage).transforms]
        for parent, child, pose in read:
            if parent == self.global_frame and child == self.odom_frame:
                self._map_to_odom = pose

    def update(self) -> Status:
        """Write map -> odom -> base once both are known."""
        if self._map_to_odom is None or self._odometry is None:
            self.feedback_message = self._waiting_for()
            return Status.RUNNING
        pose = compose(self._map_to_odom, self._odometry)
        self._set_output("robot_pose", pose)
        self.feedback_message = f"robot at ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})"
        return Status.SUCCESS

    def _waiting_for(self) -> str:
        if self._wrong_frame:
            return (f"odometry on {self.odom_topic} is in frame {self._wrong_frame!r}, "
                    f"expected {self.odom_frame!r}")
        if self._map_to_odom is None:
            return (f"waiting for localisation: no {self.global_frame} -> {self.odom_frame} "
                    f"on {self.tf_topic}")
        return f"waiting for odometry on {self.odom_topic}"
