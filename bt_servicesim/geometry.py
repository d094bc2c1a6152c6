"""Plain geometry values the mission tree passes between behaviours on the blackboard.

The tree's ports carry these small frozen values rather than ROS messages, so that goal
computation and tree tests need no ROS graph; the behaviours that talk to ROS convert at the
edge (:func:`Pose2D.from_pose`, :meth:`Pose2D.to_pose_stamped`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Pose2D:
    """A planar pose in the map frame: metres and radians."""

    x: float
    y: float
    yaw: float = 0.0

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)

    @classmethod
    def from_pose(cls, pose: Any) -> Pose2D:
        """From a ``geometry_msgs/Pose``."""
        q = pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        return cls(x=pose.position.x, y=pose.position.y, yaw=yaw)

    def to_pose(self) -> Any:
        """To a ``geometry_msgs/Pose``."""
        from geometry_msgs.msg import Pose

        pose = Pose()
        pose.position.x, pose.position.y = float(self.x), float(self.y)
        pose.orientation.z = math.sin(self.yaw / 2.0)
        pose.orientation.w = math.cos(self.yaw / 2.0)
        return pose


@dataclass(frozen=True)
class Box:
    """An axis-aligned target area, as the referee's RoomInfo service gives it."""

    min_x: float
    min_y: float
    max_x: float
    max_y: float

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.min_x + self.max_x) / 2.0, (self.min_y + self.max_y) / 2.0)

    @property
    def is_empty(self) -> bool:
        """True for the zero-size box the referee answers for an unknown room."""
        return self.max_x <= self.min_x or self.max_y <= self.min_y

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """Whether (x, y) lies inside the box shrunk by ``margin`` on every side."""
        return (self.min_x + margin <= x <= self.max_x - margin
                and self.min_y + margin <= y <= self.max_y - margin)
