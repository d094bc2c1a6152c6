"""The servicebot: a differential-drive base integrated over sim time, stopped by walls.

The engine holds the last command until the next one, as ``gazebo_ros_diff_drive`` does (no
timeout). Commands are clamped to the navigation limits (0.5 m/s, 1.0 rad/s) and integrated
exactly for a constant twist over the step. The body is a disc of the footprint's half-length
(the 0.4 x 0.5 m footprint's inscribed-to-circumscribed middle ground, 0.25 m) for contacts: a
step that would push it into a wall is refused for its translation (rotation still happens), so
the robot can scrape along a wall but never pass through one. Wall clearance comes from one
distance transform of the static map, computed when the world loads. """

from __future__ import annotations

import math

import numpy as np

from servicesim_sim.world.files import OccupancyMap

MAX_SPEED = 0.5  # m/s
MAX_TURN_RATE = 1.0  # rad/s
BODY_RADIUS = 0.25  # m


class WallClearance:
    """Metres from any point of the map to the nearest occupied or unknown cell.

    :meth:`at` runs several times a physics step: it reads the grid through a flat memoryview,
    which hands out Python floats without numpy scalars.
    """

    def __init__(self, occupancy_map: OccupancyMap) -> None:
        self.map = occupancy_map
        self.grid = occupancy_map.wall_distance.astype(np.float32)
        self._cols = self.grid.shape[1]
        self._cells = self.grid.data.cast("B").cast("f")

    def at(self, x: float, y: float) -> float:
        row, col = self.map.world_to_cell(x, y)
        if not self.map.in_bounds(row, col):
            return 0.0
        distance: float = self._cells[row * self._cols + col]
        return distance


class Robot:
    """Pose and twist of the robot base."""

    def __init__(self, *, x: float, y: float, yaw: float, walls: WallClearance) -> None:
        self.x, self.y, self.yaw = x, y, yaw
        self.v = self.w = 0.0
        self.walls = walls

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
        self.yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        if self._fits(x, y):
            self.x, self.y, self.v = x, y, v
        else:
            self.v = 0.0
        self.w = w

    def _fits(self, x: float, y: float) -> bool:
        """The body at (x, y) stays off the walls, or at least gets no deeper into them."""
        clearance = self.walls.at(x, y)
        return clearance >= BODY_RADIUS or clearance > self.walls.at(self.x, self.y)
