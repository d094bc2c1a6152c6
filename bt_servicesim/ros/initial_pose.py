"""Localisation input: the message that tells the simulator (or AMCL) where the robot starts.

A ``geometry_msgs/PoseWithCovarianceStamped`` in the map frame, published reliable and
transient-local (latched), so a simulator or localiser that joins later still receives the last
one. Both executives send it: the tree's
:class:`~bt_servicesim.behaviours.actions.publish_initial_pose.PublishInitialPose` and the
seed's state machine.
"""

from typing import Any

from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_to_msg

__all__ = [
    "INITIAL_POSE_QOS",
    "initial_pose_message",
]


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
    message.pose.pose = pose_to_msg(pose)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = POSITION_VARIANCE
    covariance[35] = YAW_VARIANCE
    message.pose.covariance = covariance
    return message


