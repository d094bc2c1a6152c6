"""The servicebot: a differential-drive base integrated over sim time, stopped by walls.

The engine holds the last command until the next one, as ``gazebo_ros_diff_drive`` does (no
timeout). Commands are clamped to the navigation limits (0.5 m/s, 1.0 rad/s) and integrated
exactly for a constant twist over the step. The body is the original's 0.4 x 0.5 m box
(:mod:`servicesim_sim.world.footprint`): it touches what it drives into, turning in place included,
and the physics stops it there, as Gazebo's would, :data:`CONTACT_SURFACE_LAYER` deep at most
(a step that would take it deeper is refused, its translation first, then its turn). The depth
it rests at is :attr:`Robot.wall_depth`, which the referee books as an object contact. Wall
clearance for the rest of the simulator comes from one distance transform of the static map,
computed when the world loads.
"""

from __future__ import annotations

import math

import numpy as np

from servicesim_sim.world.files import OccupancyMap
from servicesim_sim.world.footprint import CONTACT_SURFACE_LAYER, Footprint

MAX_SPEED = 0.5  # m/s
MAX_TURN_RATE = 1.0  # rad/s
BODY_RADIUS = 0.25  # m: a disc between the box's inscribed and circumscribed radii (task_bound)


class WallClearance:
    """Metres from any point of the map to the nearest occupied or unknown cell.

    :meth:`at` runs several times a physics step: it reads the grid through a flat memoryview,
    which hands out Python floats without numpy scalars.
    """

    def __init__(self, occupancy_map: OccupancyMap) -> None:
        self.map = occupancy_map
        self.grid = occupancy_map.wall_distance.astype(np.float32)
        self._cells = self.grid.data.cast("B").cast("f")

    def at(self, x: float, y: float) -> float:
        index = self.map.flat_index(x, y)
        if index is None:
            return 0.0
        distance: float = self._cells[index]
        return distance


class Robot:
    """Pose and twist of the robot base, and how deep its body is in a wall."""

    def __init__(self, *, x: float, y: float, yaw: float, walls: WallClearance,
                 footprint: Footprint | None = None) -> None:
        self.x, self.y, self.yaw = x, y, yaw
        self.v = self.w = 0.0
        self.walls = walls
        self.footprint = footprint or Footprint(walls.map)
        self._probed: tuple[tuple[float, float, float] | None, float] = (None, 0.0)
        self.wall_depth = self._depth(self.pose)

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.x, self.y, self.yaw

    def step(self, dt: float, *, v: float, w: float) -> None:
        """Drive with (v, w), clamped to the limits, for ``dt`` sim seconds."""
        v = max(-MAX_SPEED, min(MAX_SPEED, v))
        w = max(-MAX_TURN_RATE, min(MAX_TURN_RATE, w))
        yaw = self.yaw + w * dt
        if abs(w) > 1e-6:
            x = self.x + v / w * (math.sin(yaw) - math.sin(self.yaw))
            y = self.y - v / w * (math.cos(yaw) - math.cos(self.yaw))
        else:
            x = self.x + v * dt * math.cos(self.yaw)
            y = self.y + v * dt * math.sin(self.yaw)
        yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        start = self.pose
        for end, twist in (((x, y, yaw), (v, w)), ((self.x, self.y, yaw), (0.0, w))):
            share = self._share_that_fits(start, end)
            if share > 0.0:
                pose = _between(start, end, share)
                self.x, self.y, self.yaw = pose
                self.v, self.w = twist[0] * share, twist[1] * share
                self.wall_depth = self._depth(pose)
                return
        self.v = self.w = 0.0  # held by the wall: neither the step nor the turn alone fits

    def _fits(self, pose: tuple[float, float, float]) -> bool:
        """The body at ``pose`` is no deeper in a wall than the surface layer, or than now."""
        depth = self._depth(pose)
        return depth <= CONTACT_SURFACE_LAYER or depth <= self.wall_depth

    def _depth(self, pose: tuple[float, float, float]) -> float:
        """How deep the body is in a wall at ``pose``; the last pose measured is remembered,
        as the pose a step ends at is mostly the one it was checked at."""
        if pose != self._probed[0]:
            self._probed = (pose, self.footprint.wall_depth(pose))
        return self._probed[1]

    def _share_that_fits(self, start: tuple[float, float, float],
                         end: tuple[float, float, float]) -> float:
        """How much of the motion from ``start`` to ``end`` the body can make: all of it, or
        up to where it rests the surface layer deep in a wall (to a twentieth), or none."""
        if self._fits(end):
            return 1.0
        low, high = 0.0, 1.0
        for _ in range(5):
            middle = (low + high) / 2.0
            low, high = (middle, high) if self._fits(_between(start, end, middle)) else (
                low, middle)
        return low


def _between(start: tuple[float, float, float], end: tuple[float, float, float],
             share: float) -> tuple[float, float, float]:
    """The pose ``share`` of the way from ``start`` to ``end`` (the turn the short way)."""
    turn = math.remainder(end[2] - start[2], math.tau)
    yaw = start[2] + share * turn
    return (start[0] + share * (end[0] - start[0]), start[1] + share * (end[1] - start[1]),
            math.atan2(math.sin(yaw), math.cos(yaw)))
