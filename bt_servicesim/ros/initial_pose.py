"""Localisation input: tell the simulator (or AMCL) where the robot starts.

:class:`PublishInitialPose` publishes the pose on its ``pose`` port once per round of activity
as a ``geometry_msgs/PoseWithCovarianceStamped`` in the map frame. The publisher is reliable
and transient-local (latched), so a simulator or localiser that joins after the executive
still receives the last initial pose. Publishing is fire-and-forget: SUCCESS right after.
"""

from typing import Any

import py_trees
from geometry_msgs.msg import PoseWithCovarianceStamped
from py_trees.ports import PortInformation
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.ros.messages import pose_to_msg

__all__ = [
    "INITIAL_POSE_QOS",
    "initial_pose_message",
]

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
    message.pose.pose = pose_to_msg(pose)
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = POSITION_VARIANCE
    covariance[35] = YAW_VARIANCE
    message.pose.covariance = covariance
    return message


