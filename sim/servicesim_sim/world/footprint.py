"""The robot's body and what it touches: walls and furniture on the map, and people.

The original's servicebot is planned and driven as a 0.4 x 0.5 m box centred on its base
(``competitor_example_solution/servicebot_2dnav/config/costmap_common_params.yaml``: footprint
x ±0.2 m, y ±0.25 m; its corners 0.32 m from the centre), and its referee books every touch of
the robot with a wall, a piece of furniture or a person, by depth (``PenaltyChecker.cc``). This
module is the one place that measures those touches: :meth:`Footprint.wall_depth` says how
deep the box is in the map's obstacles, :meth:`Footprint.person_depths` how deep it is in each
person's disc (from :meth:`Footprint.gaps_to`, which navigation asks about the people it
marked). The physics (:mod:`servicesim_sim.model.robot`) stops the box at the walls, the
engine books what it touches, and navigation checks its commands with the same box. It lives
with the world because both the model and navigation need it.

Design intent:

* Depth into the map comes from a signed distance field worked out once per map: metres from
  each cell centre to the boundary between free and blocked cells, negative inside obstacles,
  read between cell centres by bilinear interpolation so that it varies smoothly with the pose
  (a 0.05 m map read cell by cell would make depths jump by whole cells). Depths are worked out
  up to :data:`DEPTH_REACH` from the free space and read as that beyond it: no body the physics
  stops at the walls, and no pose navigation looks ahead to, lies that deep.
* The box is sampled along its outline every 2.5 cm; its depth is the deepest sample. Walls are
  at least 5 cm thick, so none slips between two samples.
* A body pressed against a wall rests :data:`CONTACT_SURFACE_LAYER` deep in it, as ODE leaves
  that much penetration uncorrected (the original world's ``contact_surface_layer``,
  ``worlds/service.world.erb`` 452): the physics lets the box sink that deep and no deeper.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence

import numpy as np

from servicesim_sim.world.distance import depth_in_blocked, distance_to_blocked
from servicesim_sim.world.files import OccupancyMap

Pose = tuple[float, float, float]

HALF_LENGTH = 0.2  # m, along the robot's x (costmap_common_params.yaml's footprint)
HALF_WIDTH = 0.25  # m, along its y
CIRCUMSCRIBED_RADIUS = math.hypot(HALF_LENGTH, HALF_WIDTH)  # 0.32 m: the corners
INSCRIBED_RADIUS = min(HALF_LENGTH, HALF_WIDTH)  # 0.2 m
CONTACT_SURFACE_LAYER = 0.01  # m: ODE's allowed penetration in the original world
OUTLINE_SPACING = 0.025  # m between the outline's samples
BOUND_SLACK = 1e-9  # m: a bound is trusted only this far beyond a threshold (rounding)
DEPTH_REACH = 2.0  # m into obstacles from the free space that depths are worked out for


class WallDistance:
    """Signed metres from any point to the nearest boundary of the map's obstacles (free and
    blocked cells; outside the map counts as blocked), negative inside them; points more than
    :data:`DEPTH_REACH` deep may read about that deep (see the module docstring)."""

    def __init__(self, occupancy_map: OccupancyMap) -> None:
        self.map = occupancy_map
        blocked = np.pad(occupancy_map.blocked_mask(), 1, constant_values=True)
        half = occupancy_map.resolution / 2.0
        outside = distance_to_blocked(~blocked) * occupancy_map.resolution - half
        reach = math.ceil(DEPTH_REACH / occupancy_map.resolution)
        inside = depth_in_blocked(blocked, reach=reach) * occupancy_map.resolution - half
        self.grid = np.where(blocked, -inside, outside).astype(np.float64)
        self.grid.setflags(write=False)

    def at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Signed distances at world points, interpolated between cell centres."""
        occupancy = self.map
        # padded grid: cell (r, c) of the map is (r + 1, c + 1) here, centres at +0.5 cells
        cols = (np.asarray(xs) - occupancy.origin_x) / occupancy.resolution + 0.5
        rows = (np.asarray(ys) - occupancy.origin_y) / occupancy.resolution + 0.5
        last_row, last_col = self.grid.shape[0] - 2, self.grid.shape[1] - 2
        cols = np.minimum(np.maximum(cols, 0.0), last_col + 0.999999)
        rows = np.minimum(np.maximum(rows, 0.0), last_row + 0.999999)
        col0, row0 = np.floor(cols).astype(np.intp), np.floor(rows).astype(np.intp)
        fx, fy = cols - col0, rows - row0
        grid = self.grid
        below = grid[row0, col0] * (1.0 - fx) + grid[row0, col0 + 1] * fx
        above = grid[row0 + 1, col0] * (1.0 - fx) + grid[row0 + 1, col0 + 1] * fx
        depth: np.ndarray = below * (1.0 - fy) + above * fy
        return depth


_WALL_DISTANCES: weakref.WeakKeyDictionary[OccupancyMap, WallDistance] = (
    weakref.WeakKeyDictionary())


def wall_distance(occupancy_map: OccupancyMap) -> WallDistance:
    """The map's :class:`WallDistance`, worked out once per loaded map and shared read-only."""
    distance = _WALL_DISTANCES.get(occupancy_map)
    if distance is None:
        distance = _WALL_DISTANCES[occupancy_map] = WallDistance(occupancy_map)
    return distance


def _outline() -> tuple[np.ndarray, np.ndarray]:
    """Points along the box's edges, in the robot's frame, corners included."""
    corners = [(HALF_LENGTH, HALF_WIDTH), (-HALF_LENGTH, HALF_WIDTH),
               (-HALF_LENGTH, -HALF_WIDTH), (HALF_LENGTH, -HALF_WIDTH)]
    xs: list[float] = []
    ys: list[float] = []
    for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1], strict=True):
        steps = math.ceil(math.hypot(x1 - x0, y1 - y0) / OUTLINE_SPACING)
        xs += [x0 + (x1 - x0) * i / steps for i in range(steps)]
        ys += [y0 + (y1 - y0) * i / steps for i in range(steps)]
    return np.array(xs), np.array(ys)


class Footprint:
    """The 0.4 x 0.5 m box on one map: how deep it is in walls and in people at a pose."""

    def __init__(self, occupancy_map: OccupancyMap) -> None:
        self.map = occupancy_map
        self.walls = wall_distance(occupancy_map)
        self._outline_x, self._outline_y = _outline()
        centre_distance = np.ascontiguousarray(occupancy_map.wall_distance, dtype=np.float64)
        self._centre_distance = centre_distance.data.cast("B").cast("d")
        self._centre_slack = 1.5 * occupancy_map.resolution

    def wall_depth(self, pose: Pose) -> float:
        """Metres the box reaches into walls or furniture at ``pose`` (0 when clear)."""
        return max(0.0, -self.clearance(pose))

    def clearance(self, pose: Pose, *, beyond: float = 0.0) -> float:
        """Metres between the box at ``pose`` and the nearest wall, negative when the box is in
        one. Gaps wider than ``beyond`` are not worked out: the answer is then some gap wider
        than that (the centre's clearance less the corners' reach)."""
        x, y, yaw = pose
        near = self._centre_gap(x, y) - CIRCUMSCRIBED_RADIUS
        if near > beyond:
            return near  # no corner can come nearer than that
        cos, sin = math.cos(yaw), math.sin(yaw)
        xs = x + cos * self._outline_x - sin * self._outline_y
        ys = y + sin * self._outline_x + cos * self._outline_y
        return float(self.walls.at(xs, ys).min())

    def centre_clearance(self, x: float, y: float) -> float:
        """Metres between the point (x, y) and the nearest wall, negative inside one: the room
        the box has to turn about a centre there is this less its corners' reach."""
        return float(self.walls.at(np.array([x]), np.array([y]))[0])

    def _centre_gap(self, x: float, y: float) -> float:
        """A lower bound of the metres from (x, y) to the nearest obstacle's boundary, read
        from the map's own distance grid (cheap: this runs every physics step, through a flat
        memoryview that hands out Python floats)."""
        index = self.map.flat_index(x, y)
        if index is None:
            return 0.0
        distance: float = self._centre_distance[index]
        return distance - self._centre_slack

    def nearest_gap(self, pose: Pose, points: Sequence[tuple[float, float]], *,
                    beyond: float = 0.0) -> float:
        """Metres between the box at ``pose`` and the nearest of ``points`` (infinite when
        there are none): the least of :meth:`gaps_to`. Gaps wider than ``beyond`` are not
        worked out: the answer is then some gap wider than that (the nearest point's distance
        from the centre less the corners' reach), as :meth:`clearance` answers for walls."""
        if not points:
            return math.inf
        x, y, _ = pose
        nearest = math.inf
        for px, py in points:
            square = (px - x) * (px - x) + (py - y) * (py - y)
            if square < nearest:
                nearest = square
        near = math.sqrt(nearest) - CIRCUMSCRIBED_RADIUS - BOUND_SLACK
        if near > beyond:
            return near  # no point can be nearer the box than that
        xs = np.fromiter((px for px, _ in points), dtype=np.float64, count=len(points))
        ys = np.fromiter((py for _, py in points), dtype=np.float64, count=len(points))
        return float(self.gaps_to(pose, xs, ys).min())

    @staticmethod
    def person_depths(pose: Pose, xs: np.ndarray, ys: np.ndarray, *,
                      radius: float) -> np.ndarray:
        """Metres the box reaches into each person's disc of ``radius`` (0 when apart)."""
        return np.maximum(radius - Footprint.gaps_to(pose, xs, ys), 0.0)

    @staticmethod
    def gaps_to(pose: Pose, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Signed metres from the box at ``pose`` to each point: negative inside the box."""
        x, y, yaw = pose
        cos, sin = math.cos(yaw), math.sin(yaw)
        dx, dy = np.asarray(xs) - x, np.asarray(ys) - y
        along = np.abs(cos * dx + sin * dy) - HALF_LENGTH
        across = np.abs(-sin * dx + cos * dy) - HALF_WIDTH
        outside = np.hypot(np.maximum(along, 0.0), np.maximum(across, 0.0))
        inside = np.minimum(np.maximum(along, across), 0.0)
        gaps: np.ndarray = outside + inside
        return gaps
