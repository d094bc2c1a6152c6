"""Localisation input: tell the simulator (or AMCL) where the robot starts.

:class:`PublishInitialPose` publishes the pose on its ``pose`` port once per round of activity
as a ``geometry_msgs/PoseWithCovarianceStamped`` in the map frame. The publisher is reliable
and transient-local (latched), so a simulator or localiser that joins after the executive
still receives the last initial pose. Publishing is fire-and-forget: SUCCESS right after.
"""

from typing import Any, ClassVar

import py_trees
from geometry_msgs.msg import PoseWithCovarianceStamped
from py_trees.ports import BehaviourWithPorts, NoDataAvailable, PortInformation
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from bt_servicesim.geometry import Pose2D
from bt_servicesim.sim_time import node_from_setup_kwargs

__all__ = ["INITIAL_POSE_QOS", "PublishInitialPose", "initial_pose_message"]

Status = py_trees.common.Status
Ports = dict[str, PortInformation]
"""A port declaration: port name to its information."""

INITIAL_POSE_QOS = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""Latched, so that a late-joining subscriber still gets the pose."""

POSITION_VARIANCE = 0.25**2
"""m²: the start pose is known to about a quarter of a metre."""

YAW_VARIANCE = 0.1**2
"""rad²: and its heading to about six degrees."""


def initial_pose_message(
    pose: Pose2D, frame_id: str = "map", stamp: Any = None
) -> PoseWithCovarianceStamped:
    """The pose with a small diagonal covariance (x, y, yaw)."""
    message = PoseWithCovarianceStamped()
    message.header.frame_id = frame_id
    if stamp is not None:
        message.header.stamp = stamp
    message.pose.pose = pose.to_pose()
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = POSITION_VARIANCE
    covariance[35] = YAW_VARIANCE
    message.pose.covariance = covariance
    return message


class PublishInitialPose(BehaviourWithPorts):
    """Publish the ``pose`` port as the robot's initial pose; SUCCESS once published.

    Args:
        name: the behaviour's name
        topic: the initial pose topic
        frame_id: the frame of the pose
    """

    INPUT_PORTS: ClassVar[Ports] = {"pose": PortInformation(data_type=Pose2D, required=True)}
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def __init__(
        self,
        name: str = "PublishInitialPose",
        topic: str = "/servicebot/initialpose",
        frame_id: str = "map",
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, **kwargs)
        self.topic = topic
        self.frame_id = frame_id
        self.node: Node | None = None
        self.publisher: Publisher | None = None

    def setup(self, **kwargs: Any) -> None:
        """Create the latched publisher on ``kwargs["node"]``."""
        self.node = node_from_setup_kwargs(self.name, kwargs)
        self.publisher = self.node.create_publisher(
            PoseWithCovarianceStamped, self.topic, INITIAL_POSE_QOS
        )

    def initialise(self) -> None:
        """Nothing to start: publishing happens in the one tick."""
        self.feedback_message = f"publishing the initial pose on {self.topic}"

    def update(self) -> Status:
        """Publish, and succeed."""
        if self.node is None or self.publisher is None:
            raise RuntimeError(f"{self.name}: call setup(node=...) before ticking")
        try:
            pose = self.get_input("pose")
        except NoDataAvailable as error:
            self.feedback_message = f"no initial pose to publish: {error}"
            return Status.FAILURE
        stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(initial_pose_message(pose, self.frame_id, stamp))
        self.feedback_message = (
            f"initial pose ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f}) published on {self.topic}"
        )
        return Status.SUCCESS
