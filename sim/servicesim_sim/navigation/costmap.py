"""The navigation costmap: the static map inflated once, plus people seen by the lidar.

Costs follow Nav2's conventions (0 free, 1..252 inflated, 253 inscribed, 254 lethal). An
obstacle's cell is lethal; a cell whose centre lies within the robot's inscribed radius of one is
inscribed (the robot's centre there would touch it; the planner never enters either), and the
cost decays exponentially out to the inflation radius, as in Nav2's inflation layer, so plans
keep to the middle of doors and corridors. Which inflation layers inflate the walls and which
the people is the robot's navigation parameters' (:mod:`servicesim_sim.navigation.parameters`):
by default the servicebot's, one layer for both.

Design intent:

* The grid is coarser than the map (0.1 m against 0.05 m) and cropped to the building: the
  bounding box of the map's occupied cells plus a margin. A coarse cell takes the smallest wall
  distance of the map cells it covers, so coarsening never lets a plan closer to a wall.
* The static layer is computed once, with one Euclidean distance transform.
* The obstacle layer holds people as marks (x, y). :meth:`Costmap.observe` is a lidar sweep.
  A person is *visible* inside the ±120° field of view and 0.1–30 m range when their centre is
  in line of sight (no wall and no nearer person in the way). A visible person whose surface is
  within the marking range, 3 m, is marked: the competition's costmap marks scan hits only
  within its ``obstacle_range`` of 3 m, while it clears along every ray out to the scan's end
  (``raytrace_range`` 100 m, the lidar's 30 m). So every old mark in view with nobody there
  any more is cleared at any range, and a mark where a visible person still stands stays (the
  ray ends on them). Marks out of view stay, stale, until seen again or :meth:`Costmap.clear`.
  A person is a lethal disc (:data:`PERSON_RADIUS`), inflated by the layers that inflate
  people.
* The lidar is approximated by one ray per person to the person's centre, walls sampled on the
  map's own grid; people's legs, the scan's angular resolution and noise are not modelled.
  A sweep traces only the rays whose answer can change its result (people within the marking
  range, or near enough to an old mark in view to stand on it or hide it): rays are worked
  out one by one, so the others are not needed for the same marks, bit for bit.
"""

from __future__ import annotations

import itertools
import math
import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from servicesim_sim.navigation.parameters import SERVICEBOT, CostmapParameters, InflationLayer
from servicesim_sim.world.files import OccupancyMap

FREE = 0
MAX_INFLATED = 252
INSCRIBED = 253
LETHAL = 254

PERSON_RADIUS = 0.3  # m: a person as the lidar's marks outline them (their box, 0.44 x 0.60 m)


@dataclass(frozen=True)
class GridFrame:
    """Where a grid lies in the world: cell (row, col) spans ``resolution`` metres from the
    origin, rows growing with +y and columns with +x."""

    origin_x: float
    origin_y: float
    resolution: float
    rows: int
    cols: int

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        return (math.floor((y - self.origin_y) / self.resolution),
                math.floor((x - self.origin_x) / self.resolution))

    def centre_of(self, row: int, col: int) -> tuple[float, float]:
        return (self.origin_x + (col + 0.5) * self.resolution,
                self.origin_y + (row + 0.5) * self.resolution)

    def contains(self, row: int, col: int) -> bool:
        return 0 <= row < self.rows and 0 <= col < self.cols

    def covers(self, x: float, y: float) -> bool:
        """Whether (x, y) lies on the grid; False for non-finite or huge values, which
        :meth:`cell_of` cannot turn into a cell (``floor(inf)`` raises)."""
        col = (x - self.origin_x) / self.resolution
        row = (y - self.origin_y) / self.resolution
        return 0.0 <= row < self.rows and 0.0 <= col < self.cols

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of many cells' centres."""
        return (self.origin_x + (np.asarray(cols) + 0.5) * self.resolution,
                self.origin_y + (np.asarray(rows) + 0.5) * self.resolution)


@dataclass(frozen=True)
class Inflation:
    """Cost as a function of the distance from a cell's centre to the nearest obstacle, as
    Nav2's inflation layers make it: lethal on the obstacle, inscribed within the robot's
    inscribed radius of it, then each layer's exponential decay out to its radius, the
    highest of the layers' costs kept. Without a layer an obstacle is lethal and no more."""

    robot_radius: float
    layers: tuple[InflationLayer, ...]

    @property
    def reach(self) -> float:
        """How far from an obstacle costs reach."""
        if not self.layers:
            return 0.0
        return max(self.robot_radius, *(layer.inflation_radius for layer in self.layers))

    def costs(self, distance: np.ndarray) -> np.ndarray:
        distance = np.asarray(distance, dtype=np.float64)
        costs = np.zeros_like(distance)
        for index, layer in enumerate(self.layers):
            decay = MAX_INFLATED * np.exp(
                -layer.cost_scaling_factor * (distance - self.robot_radius))
            layer_costs = np.where(distance <= layer.inflation_radius, np.maximum(decay, 1.0),
                                   FREE)
            costs = layer_costs if index == 0 else np.maximum(costs, layer_costs)
        if self.layers:
            costs = np.where(distance <= self.robot_radius, INSCRIBED, costs)
        costs = np.where(distance <= 0.0, LETHAL, costs)
        rounded: NDArray[np.uint8] = np.rint(costs).astype(np.uint8)
        return rounded


RAY_CELL = 0.1  # metres: the lidar's rays are traced on walls pooled to about this size
RAY_FIRST_SAMPLES = 96  # a ray's samples looked at together, before the rest of the clear rays


@dataclass(frozen=True)
class Lidar:
    """The planar scanner: field of view (half angle) and range, both as in the competition,
    and the range within which the costmap marks what it hits (the competition's
    ``obstacle_range``, ``competitor_example_solution/servicebot_2dnav/config/
    costmap_common_params.yaml``)."""

    half_angle: float = math.radians(120.0)
    min_range: float = 0.1
    max_range: float = 30.0
    mark_range: float = 3.0


@dataclass(frozen=True)
class PersonMark:
    """A person the lidar saw at (x, y), at sim time ``seen_at``."""

    x: float
    y: float
    seen_at: float


class Costmap:
    """Static walls inflated once, and people marked and cleared by lidar sweeps.

    Args:
        occupancy_map: the static map (0 free, 100 occupied, -1 unknown; unknown blocks)
        layers: the robot's inscribed radius and the inflations of walls and of people
            (:class:`~servicesim_sim.navigation.parameters.CostmapParameters`; default the
            servicebot's)
        resolution: metres per costmap cell, rounded to a whole number of map cells
        crop_margin: metres kept around the bounding box of the map's occupied cells
        person_radius: a marked person is a lethal disc of this radius, inflated by the
            layers that inflate people
    """

    def __init__(self, occupancy_map: OccupancyMap, *, layers: CostmapParameters | None = None,
                 resolution: float = 0.1, crop_margin: float = 1.0,
                 person_radius: float = PERSON_RADIUS, lidar: Lidar | None = None) -> None:
        self.map = occupancy_map
        self.layers = layers or SERVICEBOT.costmap
        self.inflation = Inflation(robot_radius=self.layers.inscribed_radius,
                                   layers=self.layers.walls)
        self.people_inflation = Inflation(robot_radius=self.layers.inscribed_radius,
                                          layers=self.layers.people)
        self.person_radius = person_radius
        self.lidar = lidar or Lidar()
        self._walls = np.asarray(occupancy_map.blocked_mask(), dtype=bool)
        self._ray_grid = RayGrid(self._walls, origin=(occupancy_map.origin_x,
                                                      occupancy_map.origin_y),
                                 resolution=occupancy_map.resolution,
                                 min_range=self.lidar.min_range, max_range=self.lidar.max_range)
        self.frame, wall_distance = _kept_wall_distance(
            occupancy_map, self._walls, resolution=resolution, margin=crop_margin)
        self.static = self.inflation.costs(wall_distance)
        self.marks: tuple[PersonMark, ...] = ()
        self.visible_people: tuple[tuple[float, float], ...] = ()
        self.version = 0
        self._costs = self.static
        self._costs_version = 0

    # ------------------------------------------------------------------ queries
    def costs(self) -> np.ndarray:
        """The combined grid (static and people), rebuilt only when the marks changed."""
        if self._costs_version != self.version:
            self._costs = self._with_people(self.static.copy())
            self._costs_version = self.version
        return self._costs

    def cost_at(self, x: float, y: float) -> int:
        """Combined cost under a world point; lethal outside the grid."""
        if not self.frame.covers(x, y):
            return LETHAL
        row, col = self.frame.cell_of(x, y)
        return int(self.costs()[row, col])

    def costs_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Combined costs under many world points; lethal outside the grid.

        The same costs as :meth:`costs` holds, but while the marks have changed since that
        grid was built, the people's costs are worked out at these cells alone: the path
        follower asks about a few metres of path after every sweep, and rebuilding the whole
        grid for that was a tenth of the simulator's time.
        """
        frame = self.frame
        rows = np.floor((np.asarray(ys) - frame.origin_y) / frame.resolution).astype(np.intp)
        cols = np.floor((np.asarray(xs) - frame.origin_x) / frame.resolution).astype(np.intp)
        inside = (rows >= 0) & (rows < frame.rows) & (cols >= 0) & (cols < frame.cols)
        # integer clamps by np.maximum/np.minimum: np.clip's wrappers cost more than the work
        rows = np.minimum(np.maximum(rows, 0), frame.rows - 1)
        cols = np.minimum(np.maximum(cols, 0), frame.cols - 1)
        if self._costs_version == self.version or not self.marks:
            costs = self.costs()[rows, cols]
        else:
            centre_xs, centre_ys = frame.centres(rows, cols)
            marks = np.array([(mark.x, mark.y) for mark in self.marks])
            gaps = np.hypot(centre_xs[:, None] - marks[None, :, 0],
                            centre_ys[:, None] - marks[None, :, 1]).min(axis=1)
            costs = np.maximum(self.static[rows, cols],
                               self.people_inflation.costs(gaps - self.person_radius))
        return np.where(inside, costs, LETHAL)

    # ------------------------------------------------------------------ people
    def observe(self, robot_x: float, robot_y: float, robot_yaw: float,
                people_xy: list[tuple[float, float]] | np.ndarray, now: float) -> None:
        """One lidar sweep: mark the people in view within the marking range, clear old marks
        in view where nobody stands any more (see the module docstring).

        Only the people whose visibility can change the result get a ray (see
        :meth:`_rayed_people`); the rest are treated as unseen, which they may be.
        """
        robot = np.array([robot_x, robot_y], dtype=np.float64)
        people = _points_array(people_xy)
        current = self.marks  # read once: a sweep works on one set of marks
        old = np.array([(mark.x, mark.y) for mark in current]).reshape(-1, 2)
        count = len(people)
        distance, in_field = self._in_field(robot, robot_yaw, np.concatenate((people, old)))
        old_in_field = in_field[count:]
        surface = distance[:count] - self.person_radius
        near_people = surface <= self.lidar.mark_range
        in_sight = self._rayed_people(robot, people, surface=surface, near=near_people,
                                      in_field=in_field[:count],
                                      old_distance=distance[count:][old_in_field])
        visible, near = people[in_sight], near_people[in_sight]
        seen = visible[near]
        keep = ~_near_any(old, seen, self.person_radius)  # a person seen there marks it anew
        standing = _near_any(old, visible[~near], self.person_radius)  # the ray ends on them
        # only the other old marks in the field of view need a ray: cleared if it reaches them
        rayed = keep & ~standing & old_in_field
        if rayed.any():
            keep[rayed] = ~self._in_line_of_sight(robot, old[rayed], occluders=visible)
        marks = tuple(mark for mark, kept in zip(current, keep, strict=True) if kept)
        marks += tuple(PersonMark(float(x), float(y), now) for x, y in seen)
        self.visible_people = tuple((float(x), float(y)) for x, y in seen)
        self._set_marks(marks)

    def _rayed_people(self, robot: np.ndarray, people: np.ndarray, *, surface: np.ndarray,
                      near: np.ndarray, in_field: np.ndarray,
                      old_distance: np.ndarray) -> np.ndarray:
        """Which people the lidar sees, among those whose visibility matters; False for the rest.

        A sweep needs to know whether a person is seen only when they are within the marking
        range (they are marked), near an old mark in the field of view (the ray ends on them
        and the mark stays) or nearer than such a mark (they may hide it). Farther people are
        left unrayed: a person can neither stand within the person radius of a mark nor hide it
        unless they are less than a metre farther than it (a generous margin over rounding).
        Rays to far people behind walls were most of a sweep's cost. ``in_field``: whether
        each person is in the field of view; ``old_distance``: how far each old mark in it is.
        """
        reach = (old_distance.max() - self.person_radius + 1.0 if old_distance.size
                 else -math.inf)
        wanted = in_field & (near | (surface < reach))
        in_sight = np.zeros(len(people), dtype=bool)
        if wanted.any():
            in_sight[wanted] = self._in_line_of_sight(robot, people[wanted], occluders=people)
        return in_sight

    def clear(self) -> None:
        """Forget every mark (what clear_costmaps does)."""
        self._set_marks(())

    def clear_beyond(self, x: float, y: float, reach: float) -> None:
        """Forget the marks outside the square of half side ``reach`` round (x, y), keeping
        those near: move_base's conservative reset (``clear_costmap_recovery`` clears outside a
        ``reset_distance`` square round the robot)."""
        self._set_marks(tuple(mark for mark in self.marks
                              if abs(mark.x - x) <= reach and abs(mark.y - y) <= reach))

    def _set_marks(self, marks: tuple[PersonMark, ...]) -> None:
        if sorted((m.x, m.y) for m in marks) != sorted((m.x, m.y) for m in self.marks):
            self.version += 1
        self.marks = marks

    def costs_with(self, people: list[tuple[float, float]]) -> np.ndarray:
        """The static costs with ``people`` marked, as if the lidar had seen them all (the
        marks themselves are left as they are)."""
        marks = tuple(PersonMark(float(x), float(y), 0.0) for x, y in people)
        return self._with_people(self.static.copy(), marks=marks)

    def _with_people(self, costs: np.ndarray,
                     marks: tuple[PersonMark, ...] | None = None) -> np.ndarray:
        reach = self.person_radius + self.people_inflation.reach
        frame = self.frame
        for mark in self.marks if marks is None else marks:
            row0, col0 = frame.cell_of(mark.x - reach, mark.y - reach)
            row1, col1 = frame.cell_of(mark.x + reach, mark.y + reach)
            row0, col0 = max(row0, 0), max(col0, 0)
            row1, col1 = min(row1, frame.rows - 1), min(col1, frame.cols - 1)
            if row0 > row1 or col0 > col1:
                continue
            rows, cols = np.mgrid[row0:row1 + 1, col0:col1 + 1]
            xs, ys = frame.centres(rows, cols)
            gap = np.hypot(xs - mark.x, ys - mark.y) - self.person_radius
            window = costs[row0:row1 + 1, col0:col1 + 1]
            np.maximum(window, self.people_inflation.costs(gap), out=window)
        return costs

    # ------------------------------------------------------------------ the lidar
    def _in_field(self, robot: np.ndarray, yaw: float,
                  targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How far each target's centre is, and whether it lies in the lidar's field of view
        and range (walls and people aside); element by element, so the people and the old
        marks are looked at in one go."""
        offsets = targets - robot
        distance = np.hypot(offsets[:, 0], offsets[:, 1])
        surface = distance - self.person_radius
        bearing = np.arctan2(offsets[:, 1], offsets[:, 0]) - yaw
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        in_field: NDArray[np.bool_] = ((np.abs(bearing) <= self.lidar.half_angle)
                                       & (surface >= self.lidar.min_range)
                                       & (surface <= self.lidar.max_range))
        return distance, in_field

    def _in_line_of_sight(self, robot: np.ndarray, targets: np.ndarray, *,
                          occluders: np.ndarray) -> np.ndarray:
        """Whether each ray to a target misses every wall and every nearer occluder; each
        target's answer depends on it alone, so any subset of targets may be asked."""
        clear = self._wall_free(robot, targets)
        open_rays = np.flatnonzero(clear)  # a ray stopped by a wall needs no people test
        if open_rays.size:
            clear[open_rays] = ~self._hidden_by_people(robot, targets[open_rays], occluders)
        return clear

    def _wall_free(self, robot: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Whether each ray from the robot to a target's surface misses every wall cell.

        Rays are sampled every cell of the ray grid (:class:`RayGrid`): sample ``k`` lies
        ``min_range + k * cell`` along the ray. Samples one cell apart cannot step over a
        straight wall one cell thick, only clip its corners. The first
        :data:`RAY_FIRST_SAMPLES` samples of every ray are looked at in one rectangular array
        (cheaper to build than a flat one); only the longer rays still clear go on to the rest
        of their samples, in one flat array. The same samples, the same arithmetic: a ray is
        free when none of its samples is a wall (most rays meet one within a few metres).
        """
        if len(targets) == 0:
            return np.zeros(0, dtype=bool)
        offsets = targets - robot
        distance = np.maximum(np.hypot(offsets[:, 0], offsets[:, 1]), 1e-9)
        lengths = distance - self.person_radius
        grid = self._ray_grid
        counts = np.floor(np.maximum(lengths - self.lidar.min_range, 0.0)
                          / grid.cell).astype(np.intp) + 1
        across, up = offsets[:, 0] / distance, offsets[:, 1] / distance
        first = grid.samples_along(min(RAY_FIRST_SAMPLES, int(counts.max())))
        hits = grid.walls_at(robot[0] + across[:, None] * first, robot[1] + up[:, None] * first)
        hits &= np.arange(first.size) < counts[:, None]  # samples past a short ray's end
        free: NDArray[np.bool_] = ~np.logical_or.reduce(hits, axis=1)
        longer = np.flatnonzero(free & (counts > first.size))
        if longer.size:
            rest = counts[longer] - first.size
            starts = np.cumsum(rest) - rest
            along = grid.samples_along(int(counts.max()))[
                np.arange(int(rest.sum())) - np.repeat(starts, rest) + first.size]
            hits = grid.walls_at(robot[0] + np.repeat(across[longer], rest) * along,
                                 robot[1] + np.repeat(up[longer], rest) * along)
            free[longer] = ~np.logical_or.reduceat(hits, starts)
        return free

    def _hidden_by_people(self, robot: np.ndarray, targets: np.ndarray,
                          occluders: np.ndarray) -> np.ndarray:
        """Whether a nearer person's disc crosses each ray from the robot to a target."""
        if occluders.size == 0:
            return np.zeros(len(targets), dtype=bool)
        offsets = targets - robot
        distance = np.maximum(np.hypot(offsets[:, 0], offsets[:, 1]), 1e-9)
        unit = offsets / distance[:, None]
        relative = occluders[None, :, :] - robot[None, None, :]
        along = np.einsum("tod,td->to", relative, unit)
        across = np.abs(relative[:, :, 0] * unit[:, None, 1] - relative[:, :, 1] * unit[:, None, 0])
        in_front = (along > 0.0) & (along < distance[:, None] - self.person_radius)
        # np.logical_or.reduce is np.any without its wrappers (a sweep's fixed costs)
        hidden: NDArray[np.bool_] = np.logical_or.reduce(
            in_front & (across < self.person_radius), axis=1)
        return hidden


class RayGrid:
    """The wall grid the lidar's rays are traced on.

    A map finer than ``cell`` is pooled into blocks of about that size, a block being a wall
    where any of its cells is: walls grow by less than a block, and a ray needs a half or a
    quarter of the samples it would need on the map itself. The grid is kept framed by one
    row and column of wall on every side, so a sample off the grid reads as a wall without
    a test of its own; ``along`` holds the distances of the samples along a ray.
    """

    def __init__(self, walls: np.ndarray, *, origin: tuple[float, float], resolution: float,
                 min_range: float, max_range: float, cell: float = RAY_CELL) -> None:
        factor = max(1, round(cell / resolution))
        height, width = walls.shape
        padded = np.pad(walls, ((0, -height % factor), (0, -width % factor)))
        self.walls = padded.reshape(padded.shape[0] // factor, factor,
                                    padded.shape[1] // factor, factor).any(axis=(1, 3))
        self.cell = resolution * factor
        self.origin_x, self.origin_y = origin
        self._framed = np.pad(self.walls, 1, constant_values=True).ravel()
        self._rows, self._cols = self.walls.shape
        self.min_range = min_range
        count = math.floor(max(max_range - min_range, 0.0) / self.cell) + 2
        self.along = min_range + np.arange(max(count, RAY_FIRST_SAMPLES)) * self.cell

    def samples_along(self, count: int) -> np.ndarray:
        """The distances along a ray of its first ``count`` samples (``along`` when it has
        them all)."""
        if count <= self.along.size:
            return self.along[:count]
        return self.min_range + np.arange(count) * self.cell

    def walls_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether the cells under the points are walls; True off the grid."""
        cols = np.floor((xs - self.origin_x) / self.cell).astype(np.intp)
        rows = np.floor((ys - self.origin_y) / self.cell).astype(np.intp)
        # off the grid is clamped onto the frame; np.maximum/np.minimum, not np.clip's wrappers
        np.minimum(np.maximum(cols, -1, out=cols), self._cols, out=cols)
        np.minimum(np.maximum(rows, -1, out=rows), self._rows, out=rows)
        rows += 1
        rows *= self._cols + 2
        rows += cols
        rows += 1
        return self._framed[rows]


def _points_array(points: list[tuple[float, float]] | np.ndarray) -> np.ndarray:
    """``points`` as an (n, 2) float array; a list of pairs is read as one flat run of numbers
    (a third of the cost of numpy's reading of nested sequences, a sweep's fixed costs)."""
    if isinstance(points, np.ndarray):
        return np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.fromiter(itertools.chain.from_iterable(points), dtype=np.float64,
                       count=2 * len(points)).reshape(-1, 2)


def _near_any(points: np.ndarray, others: np.ndarray, radius: float) -> np.ndarray:
    """Which points lie within ``radius`` of any of the others."""
    if points.size == 0 or others.size == 0:
        return np.zeros(len(points), dtype=bool)
    gaps = np.hypot(points[:, None, 0] - others[None, :, 0],
                    points[:, None, 1] - others[None, :, 1])
    near: NDArray[np.bool_] = np.logical_or.reduce(gaps <= radius, axis=1)
    return near


_WALL_DISTANCES: weakref.WeakKeyDictionary[
    OccupancyMap, dict[tuple[float, float], tuple[GridFrame, np.ndarray]]] = (
    weakref.WeakKeyDictionary())


def _kept_wall_distance(occupancy_map: OccupancyMap, walls: np.ndarray, *,
                        resolution: float, margin: float) -> tuple[GridFrame, np.ndarray]:
    """:func:`_coarse_wall_distance` of the map's walls, once per loaded map, resolution and
    margin: the episodes a reset plays on one world share it, read-only."""
    kept = _WALL_DISTANCES.setdefault(occupancy_map, {})
    found = kept.get((resolution, margin))
    if found is None:
        frame, distance = _coarse_wall_distance(occupancy_map, walls, resolution=resolution,
                                                margin=margin)
        distance.setflags(write=False)
        found = kept[(resolution, margin)] = (frame, distance)
    return found


def _coarse_wall_distance(occupancy_map: OccupancyMap, walls: np.ndarray, *,
                          resolution: float, margin: float) -> tuple[GridFrame, np.ndarray]:
    """The costmap's frame and, per coarse cell, metres to the nearest wall cell.

    The frame covers the bounding box of the occupied cells (blocked and known) plus
    ``margin``, clipped to the map and grown to whole coarse cells; anything beyond the frame or
    the map counts as wall.
    """
    fine = float(occupancy_map.resolution)
    factor = max(1, round(resolution / fine))
    occupied_rows, occupied_cols = np.nonzero(walls & (np.asarray(occupancy_map.grid) >= 0))
    height, width = walls.shape
    if occupied_rows.size:
        pad = math.ceil(margin / fine)
        row0, row1 = max(occupied_rows.min() - pad, 0), min(occupied_rows.max() + pad + 1, height)
        col0, col1 = max(occupied_cols.min() - pad, 0), min(occupied_cols.max() + pad + 1, width)
    else:
        row0, row1, col0, col1 = 0, height, 0, width
    rows, cols = -(-(row1 - row0) // factor), -(-(col1 - col0) // factor)
    window = np.ones((rows * factor, cols * factor), dtype=bool)
    window[:row1 - row0, :col1 - col0] = walls[row0:row1, col0:col1]
    walled = np.pad(window, 1, constant_values=True)  # beyond the map is wall
    distance = ndimage.distance_transform_edt(~walled)[1:-1, 1:-1] * fine
    coarse = distance.reshape(rows, factor, cols, factor).min(axis=(1, 3))
    frame = GridFrame(origin_x=float(occupancy_map.origin_x) + int(col0) * fine,
                      origin_y=float(occupancy_map.origin_y) + int(row0) * fine,
                      resolution=factor * fine, rows=int(rows), cols=int(cols))
    return frame, coarse
