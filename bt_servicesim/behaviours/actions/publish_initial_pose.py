"""Localisation input: publish the pose the robot starts at, once per round of activity."""

from typing import Any

from geometry_msgs.msg import PoseWithCovarianceStamped
from py_trees.ports import NoDataAvailable, PortInformation
from rclpy.node import Node
from rclpy.publisher import Publisher

from bt_servicesim.behaviours.node import ActionNode, Ports, Status
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.initial_pose import INITIAL_POSE_QOS, initial_pose_message
from bt_servicesim.ros.sim_clock import node_from_setup_kwargs


class PublishInitialPose(ActionNode):
    """Publish the ``pose`` port as the robot's initial pose; SUCCESS once published.

    Args:
        name: the behaviour's name
        topic: the initial pose topic
        frame_id: the frame of the pose
    """

    INPUT_PORTS: Ports = {"pose": PortInformation(data_type=Pose2D, required=True)}
    OUTPUT_PORTS: Ports = {}

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
        self.publisher: Publisher[PoseWithCovarianceStamped] | None = None

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
