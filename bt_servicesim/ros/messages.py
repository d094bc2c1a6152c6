"""Between ROS messages and the plain values the tree passes around: the only place they meet.

The planning code and the blackboard work with :class:`~bt_servicesim.planning.geometry.Pose2D`
and :class:`~bt_servicesim.planning.geometry.Box`, which know nothing of ROS; behaviours that
talk to ROS convert at the edge with these functions.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import Pose, Quaternion, Transform

from bt_servicesim.planning.geometry import Pose2D, yaw_of

__all__ = ["pose_from_msg", "pose_from_transform", "pose_to_msg"]


def _yaw(q: Quaternion) -> float:
    return yaw_of(q.x, q.y, q.z, q.w)


def pose_from_msg(pose: Pose) -> Pose2D:
    """The planar pose of a ``geometry_msgs/Pose``: x, y and the yaw of its quaternion."""
    return Pose2D(x=pose.position.x, y=pose.position.y, yaw=_yaw(pose.orientation))


def pose_from_transform(transform: Transform) -> Pose2D:
    """The planar part of a ``geometry_msgs/Transform``: the child frame's origin in the
    parent's, x, y and yaw."""
    translation = transform.translation
    return Pose2D(x=translation.x, y=translation.y, yaw=_yaw(transform.rotation))


def pose_to_msg(pose: Pose2D) -> Pose:
    """A ``geometry_msgs/Pose`` on the ground plane with ``pose``'s position and yaw."""
    message = Pose()
    message.position.x, message.position.y = float(pose.x), float(pose.y)
    message.orientation.z = math.sin(pose.yaw / 2.0)
    message.orientation.w = math.cos(pose.yaw / 2.0)
    return message
