"""Navigation goals as Nav2's bt_navigator takes them: brought into ``map``, or refused.

Nav2 transforms a NavigateToPose goal from its header's frame into the global frame before it
plans, and aborts the goal when it cannot: TF_ERROR for a frame it has no transform from, a
failure for a goal no path can be planned to. :func:`goal_in_map` does the same for the
simulator, whose tf tree has two frames a goal may name: ``map`` (the global frame) and
``odom``. Anything else, the empty frame included, is a frame nobody publishes.

Design intent:

* ``odom`` goes through the one function that knows where odometry's origin lies in the map
  (:meth:`servicesim_sim.model.engine.SimEngine.map_to_odom`, handed in as ``map_to_odom``): today's
  odometry is reported in ``map``, so it is the identity, and when odometry starts at zero at
  the spawn pose only that function changes.
* A goal is refused, never executed as something it is not: a non-finite position, a zero or
  non-finite quaternion ("invalid orientation"), and a goal that lies off the map, which the
  planner could never reach (Nav2's planner fails to plan to it; the navigator aborts). A
  quaternion that is merely not normalised is normalised, as tf2 does when it reads one.
* The checks are pure functions of the goal's numbers, so they are tested without ROS; the
  node only turns a :class:`GoalRefusal` into an aborted result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from servicesim_sim.navigation.body_check import Pose
from servicesim_sim.navigation.navigator import NavigateToPoseError

GLOBAL_FRAME = "map"
ODOM_FRAME = "odom"
#: Shorter than this, a quaternion gives no direction: its normalisation is noise.
MIN_QUATERNION_NORM = 1e-6

Extent = tuple[float, float, float, float]  # min_x, min_y, max_x, max_y


@dataclass(frozen=True)
class GoalPose:
    """A goal's numbers as the message carries them: frame, position and orientation."""

    frame_id: str
    position: tuple[float, float, float]  # x, y, z
    orientation: tuple[float, float, float, float]  # x, y, z, w


@dataclass(frozen=True)
class GoalRefusal:
    """Why a goal is aborted: NavigateToPose's error code and a sentence naming the problem."""

    error_code: int
    error_msg: str


def goal_in_map(goal: GoalPose, *, map_extent: Extent,
                map_to_odom: Pose) -> Pose | GoalRefusal:
    """The goal as (x, y, yaw) in ``map``, or why it is refused (see the module docstring)."""
    refusal = (_frame_refusal(goal.frame_id) or _position_refusal(goal.position)
               or _orientation_refusal(goal.orientation))
    if refusal is not None:
        return refusal
    pose = (goal.position[0], goal.position[1], yaw_of(goal.orientation))
    if goal.frame_id == ODOM_FRAME:
        pose = compose(map_to_odom, pose)
    return _off_map_refusal(pose, map_extent) or pose


def yaw_of(orientation: tuple[float, float, float, float]) -> float:
    """The heading of a quaternion (x, y, z, w) of any non-zero length."""
    x, y, z, w = normalised(orientation)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def normalised(orientation: tuple[float, float, float, float]
               ) -> tuple[float, float, float, float]:
    """The quaternion scaled to length 1 (``math.hypot`` does not overflow on huge parts)."""
    norm = math.hypot(*orientation)
    x, y, z, w = orientation
    return x / norm, y / norm, z / norm, w / norm


def compose(frame: Pose, pose: Pose) -> Pose:
    """``pose``, given in a frame whose origin lies at ``frame``, in the outer frame."""
    fx, fy, fyaw = frame
    x, y, yaw = pose
    cos, sin = math.cos(fyaw), math.sin(fyaw)
    heading = fyaw + yaw
    return (fx + cos * x - sin * y, fy + sin * x + cos * y,
            math.atan2(math.sin(heading), math.cos(heading)))


def _frame_refusal(frame_id: str) -> GoalRefusal | None:
    if frame_id in (GLOBAL_FRAME, ODOM_FRAME):
        return None
    return GoalRefusal(
        NavigateToPoseError.TF_ERROR,
        f"failed to transform the goal from frame {frame_id!r} to the global frame "
        f"{GLOBAL_FRAME!r}: no transform from {frame_id!r} (the simulator's frames a goal may "
        f"name: {GLOBAL_FRAME!r}, {ODOM_FRAME!r})")


def _position_refusal(position: tuple[float, float, float]) -> GoalRefusal | None:
    if all(math.isfinite(value) for value in position):
        return None
    x, y, z = position
    return GoalRefusal(NavigateToPoseError.UNKNOWN,
                       f"invalid goal: position ({x}, {y}, {z}) is not finite")


def _orientation_refusal(orientation: tuple[float, float, float, float]) -> GoalRefusal | None:
    x, y, z, w = orientation
    if not all(math.isfinite(value) for value in orientation):
        problem = "is not finite"
    elif math.hypot(*orientation) < MIN_QUATERNION_NORM:
        problem = "has (nearly) zero length"
    else:
        return None
    return GoalRefusal(NavigateToPoseError.UNKNOWN,
                       f"invalid orientation: quaternion (x {x}, y {y}, z {z}, w {w}) {problem}")


def _off_map_refusal(pose: Pose, extent: Extent) -> GoalRefusal | None:
    x, y, _ = pose
    low_x, low_y, high_x, high_y = extent
    if low_x <= x < high_x and low_y <= y < high_y:
        return None
    return GoalRefusal(
        NavigateToPoseError.UNKNOWN,
        f"failed to plan to the goal: ({x:g}, {y:g}) in {GLOBAL_FRAME!r} lies outside the map "
        f"(x {low_x:g}..{high_x:g}, y {low_y:g}..{high_y:g})")
