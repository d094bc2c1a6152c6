"""Plain geometry values the mission tree passes between behaviours on the blackboard.

The tree's ports carry these small frozen values rather than ROS messages, so that goal
computation and tree tests need no ROS graph; the behaviours that talk to ROS convert at the
edge (:mod:`bt_servicesim.ros.messages`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Point = tuple[float, float]
"""A point in the map frame: metres."""


@dataclass(frozen=True)
class Pose2D:
    """A planar pose in the map frame: metres and radians."""

    x: float
    y: float
    yaw: float = 0.0

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)


def yaw_of(qx: float, qy: float, qz: float, qw: float) -> float:
    """The rotation about z of the quaternion (x, y, z, w): a planar pose's heading."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def compose(frame: Pose2D, pose: Pose2D) -> Pose2D:
    """``pose``, given in a frame whose origin lies at ``frame``, in the frame ``frame`` is
    given in: the planar transform product frame * pose.

    How tf2 chains transforms: map -> odom (from localisation) composed with odom -> base
    (odometry) is the robot's pose in map.
    """
    cos, sin = math.cos(frame.yaw), math.sin(frame.yaw)
    yaw = math.atan2(math.sin(frame.yaw + pose.yaw), math.cos(frame.yaw + pose.yaw))
    return Pose2D(x=frame.x + cos * pose.x - sin * pose.y,
                  y=frame.y + sin * pose.x + cos * pose.y, yaw=yaw)


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
