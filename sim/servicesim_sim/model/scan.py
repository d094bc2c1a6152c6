"""The lidar's ranges: one planar sweep on the map's walls and the people, with no ROS in it.

The original's lidar (``servicebot.urdf``, sensor ``lidar`` on ``lidar_frame``, 0.05 m ahead of
the base and 0.969 m up) sweeps 1875 beams over +-120 degrees, 0.1 to 30 m, with Gaussian noise
of 0.008 m, ten times a second. This sweep has the same beams. Walls are found by sphere
tracing on the wall-clearance grid the robot already has (each step advances by the distance to
the nearest wall, so a beam needs a few dozen lookups however long it is); people are discs of
the body radius the referee uses, hit exactly. A beam that meets nothing within range reads
``inf``, as ``sensor_msgs/LaserScan`` says a sensor should. Noise is drawn from the seeded
generator it is handed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from servicesim_sim.model.localisation import Pose, compose

LIDAR_OFFSET: Pose = (0.05, 0.0, 0.0)  # lidar_frame in base_footprint, in the plane
LIDAR_HEIGHT_M = 0.749 + 0.22  # base_footprint -> base_link -> lidar_frame
SURFACE_M = 0.02  # a beam this close to a wall has hit it
MAX_STEPS = 256  # sphere-tracing steps per beam; a beam still short of a wall reads inf


def surface_clearance(grid: np.ndarray, *, origin: tuple[float, float],
                      resolution: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A vectorised lookup of metres to the nearest wall's surface, from a grid of metres
    between cell centres (:class:`servicesim_sim.model.robot.WallClearance`); 0 off the grid."""
    height, width = grid.shape
    surface = np.maximum(grid - resolution / 2.0, 0.0)

    def lookup(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        cols = np.floor((xs - origin[0]) / resolution).astype(np.intp)
        rows = np.floor((ys - origin[1]) / resolution).astype(np.intp)
        inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
        found = surface[np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1)]
        return np.where(inside, found, 0.0)

    return lookup


@dataclass(frozen=True)
class LidarSpec:
    """The scanner, as the original's urdf declares it."""

    samples: int = 1875
    angle_min: float = -2.0943951023931953
    angle_max: float = 2.0943951023931953
    range_min: float = 0.1
    range_max: float = 30.0
    noise_std: float = 0.008
    rate_hz: float = 10.0

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.samples - 1)

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(self.samples)


class Scanner:
    """Ranges of one sweep from a robot pose, on walls given as a clearance lookup.

    Args:
        clearance: metres from a map point to the nearest wall (vectorised over arrays)
        spec: the scanner
        person_radius: people are discs of this radius
    """

    def __init__(self, *, clearance: Callable[[np.ndarray, np.ndarray], np.ndarray],
                 spec: LidarSpec | None = None, person_radius: float = 0.25) -> None:
        self.clearance = clearance
        self.spec = spec or LidarSpec()
        self.person_radius = person_radius
        self._angles = self.spec.angles()

    def ranges(self, robot: Pose, people: Sequence[tuple[float, float]],
               rng: np.random.Generator | None = None) -> np.ndarray:
        """One sweep from the robot at ``robot`` (base_footprint in map): float32 ranges."""
        x, y, yaw = compose(robot, LIDAR_OFFSET)
        directions = yaw + self._angles
        dx, dy = np.cos(directions), np.sin(directions)
        hits = np.minimum(self._walls(x, y, dx, dy), self._people(x, y, dx, dy, people))
        if rng is not None and self.spec.noise_std > 0.0:
            hits = hits + rng.normal(0.0, self.spec.noise_std, hits.shape)
        spec = self.spec
        hits = np.where((hits >= spec.range_min) & (hits <= spec.range_max), hits, np.inf)
        return hits.astype(np.float32)

    def _walls(self, x: float, y: float, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        travelled = np.zeros_like(dx)
        active = np.ones(dx.shape, dtype=bool)
        hit = np.full(dx.shape, np.inf)
        for _ in range(MAX_STEPS):
            index = np.flatnonzero(active)
            if index.size == 0:
                break
            along = travelled[index]
            gap = self.clearance(x + dx[index] * along, y + dy[index] * along)
            touching = gap <= SURFACE_M
            hit[index[touching]] = along[touching]
            travelled[index] = along + np.maximum(gap, SURFACE_M)
            active[index] = ~touching & (travelled[index] <= self.spec.range_max)
        return hit

    def _people(self, x: float, y: float, dx: np.ndarray, dy: np.ndarray,
                people: Sequence[tuple[float, float]]) -> np.ndarray:
        hit = np.full(dx.shape, np.inf)
        for px, py in people:
            ox, oy = px - x, py - y
            if math.hypot(ox, oy) > self.spec.range_max + self.person_radius:
                continue
            along = dx * ox + dy * oy
            across_sq = ox * ox + oy * oy - along * along
            inside = np.maximum(self.person_radius ** 2 - across_sq, 0.0)
            entry = along - np.sqrt(inside)
            meets = (across_sq <= self.person_radius ** 2) & (entry > 0.0)
            hit = np.where(meets, np.minimum(hit, entry), hit)
        return hit
