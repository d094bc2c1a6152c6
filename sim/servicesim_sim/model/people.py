"""The office's other people: walkers on looping routes and idlers standing still.

The original competition's rules (osrf/servicesim, ``servicesim_competition``): 10 walkers at
0.9–1.2 m/s on looping routes, each stopping while anyone (the robot, the guest, another
walker; routes keep every idler out of the lanes) is in a lane 1.5 m ahead and ±0.6 m wide, and
waiting as long as it stays blocked (``src/TrajectoryActorPlugin.cc``); 30 idlers, each at a
random point of one of the world's idling areas, facing the area's yaw ± 0.5 rad, at least 1 m
from the others (``worlds/idling_humans.erb``). Every one of them is called ``human_NNNNN``
and is an obstacle; the engine decides what touching one costs, this module only says where
they are.

Design intent:

* Everything is decided at construction from the given random generator, so one seed gives one
  crowd. Stepping is cheap (arc length along a precomputed polyline) and draws nothing random.
* People stay inside the building: the bounding box of the map's occupied cells, so a map whose
  outside is free (the competition's own) keeps nobody on the lawn.
* Idlers are placed first. A world with idling areas gets them there, on free cells, as the
  original placed them; a world without gets them anywhere 0.6 m clear of walls. Either way no
  target keeps them away: they only never stand on somebody already there (the guest, the
  robot's start: the ``occupied`` discs), and an idler is refused where it would cut a passage
  the robot needs (the robot-passable free space must not split), so no seed makes a room
  unreachable.
* A world with walker routes (the office: the original's hand-drawn loops) has each walker draw
  one as the original's world generator did (``worlds/service.world.erb`` 397-405,
  ``worlds/actor_trajectory.erb`` 14-45): a route by its weight, a speed of 0.9-1.2 m/s and a
  first waypoint (``rand(0..20)`` round the loop, the next one while another walker starts
  there), walking the loop one way; the fixed task may name its walkers instead (the shipped
  world file's ten). Anyone stops such a walker, idlers too, as the original's actors did.
* Elsewhere, or with ``random_routes``, walker routes are ours: planned after the idlers on a
  coarse grid of the free space eroded by 0.5 m, with the keep-clear discs and the idlers cut
  out, straightened by line of sight, and redrawn until nobody standing still (an idler, the
  waiting guest) ever comes into a walker's lane: a walker stopped by someone who never moves
  would stand there for the whole run.
"""

from __future__ import annotations

import bisect
import itertools
import math
import weakref
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, overload

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra

from servicesim_sim.world.files import IdlingArea, OccupancyMap, PlacedWalker, WalkerRoute

WALKER = "walker"
IDLER = "idler"

PERSON_RADIUS = 0.25  # metres; a person's footprint seen as a disc
WALKER_SPEED_RANGE = (0.9, 1.2)  # m/s
WALKER_STOP_DISTANCE = 1.5  # anyone nearer than this ahead of a walker ... (obstacle_margin)
WALKER_LANE_HALF_WIDTH = 0.4 * WALKER_STOP_DISTANCE  # ... and this near its line stops it
ROBOT_BELOW_WALKER = 1.0  # metres: the stop distance is measured in 3-D (TrajectoryActorPlugin.cc
# 186-199, ``modelPos.Length()``) from a walker's origin 1.0 m up (its waypoints' z, as the
# guest's) to the robot's on the floor (``base_footprint``): the robot stops it from about 1.12 m
WALKER_WALL_CLEARANCE = 0.5  # route nodes and straightened legs keep this far from walls
WALKER_IDLER_CLEARANCE = 0.75  # ... and this far from idlers (beyond the lane's half-width)
WALKER_STANDOFF_S = 5.0  # a walker blocked by walkers alone this long turns back (ours: the
# original's hand-drawn loops run one way and rarely meet head on; random loops do, and without
# this every walker of the office stands deadlocked within about 100 s)
LANE_WINDOW_M = WALKER_STOP_DISTANCE + 1e-9  # a point farther along x is never in the lane,
# whatever the rounding of the bounds (far below a nanometre where walkers walk)
STANDING_SLACK = 1e-6  # metres: a standing point this much beyond the stop distance of a leg
# is still taken for near it (rounding of a walker's place on the leg is far below that)
STOP_SEARCH_STEP = 0.05  # metres between the spots of a loop searched for a lasting stop
ROUTE_DRAWS = 50  # loops drawn per walker before giving up on one clear of standing people
FIRST_WAYPOINT_DRAW = 21  # the original draws a walker's first waypoint as rand(0..20)
ROUTE_CELL = 0.25  # metres per route-grid cell
ROUTE_WAYPOINTS = (3, 4)  # a route loops through this many random waypoints (inclusive)
ROUTE_MIN_LEG = 4.0  # consecutive waypoints at least this far apart when the space allows
LINES_AT_ONCE = 16  # a route's corners checked for a clear straight line together
IDLER_SPACING = 1.0
IDLER_YAW_SPREAD = 0.5  # radians either side of an idling area's yaw
IDLER_WALL_CLEARANCE = 0.6  # where a world has no idling areas
ROBOT_PASSAGE_CLEARANCE = 0.35  # free space the robot needs around its centre
PASSAGE_CELL = 0.10  # metres per cell of the robot-passage connectivity grid
POCKET_M2 = 1.0  # an idler may cut off a pocket of robot-passable floor this small, no more
PLACEMENT_DRAWS = 200  # random spots drawn per idler before giving up

NAME_NUMBERS = 100_000  # human_00000 .. human_99999

KeepClear = tuple[float, float, float]  # (x, y, radius) in metres


class CrowdError(ValueError):
    """The map has no room for the people the world asks for; the message is one line."""


class WalkerStartError(CrowdError):
    """A walker's drawn route has no waypoint left to start at (the others' starts and the
    task's bodies take them all): the original's generator failed so too, and the draw is
    made again (:mod:`servicesim_sim.model.playable`)."""


@dataclass
class Person:
    """One walker or idler; ``yaw`` is the way they face (a walker: the way they walk)."""

    name: str
    role: str  # WALKER | IDLER
    x: float
    y: float
    yaw: float


# --------------------------------------------------------------------------------- free space
_CLEARANCES: weakref.WeakKeyDictionary[OccupancyMap, Clearance] = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class Clearance:
    """Distance (metres) to the nearest blocked cell, for each map cell inside the building.

    The window is the bounding box of the map's occupied cells and its border counts as a wall.
    Window cell (r, c) is map cell (row0 + r, col0 + c); rows grow with +y, columns with +x.
    """

    metres: np.ndarray
    row0: int
    col0: int
    resolution: float
    origin_x: float
    origin_y: float

    @classmethod
    def of(cls, occupancy_map: OccupancyMap) -> Clearance:
        """The map's clearance, once per loaded map: the episodes a reset plays on one world
        share it, read-only."""
        clearance = _CLEARANCES.get(occupancy_map)
        if clearance is None:
            clearance = _CLEARANCES[occupancy_map] = cls._measured(occupancy_map)
            clearance.metres.setflags(write=False)
        return clearance

    @classmethod
    def _measured(cls, occupancy_map: OccupancyMap) -> Clearance:
        blocked = np.asarray(occupancy_map.blocked_mask(), dtype=bool)
        occupied = blocked & (np.asarray(occupancy_map.grid) != -1)
        rows, cols = np.nonzero(occupied if occupied.any() else ~blocked)
        if rows.size == 0:
            raise CrowdError("the occupancy map has neither free nor occupied cells")
        window = blocked[rows.min():rows.max() + 1, cols.min():cols.max() + 1]
        walled = np.pad(window, 1, constant_values=True)
        cells = ndimage.distance_transform_edt(~walled)[1:-1, 1:-1]
        metres = np.maximum(cells - 0.5, 0.0) * occupancy_map.resolution
        return cls(metres=metres.astype(np.float32), row0=int(rows.min()), col0=int(cols.min()),
                   resolution=float(occupancy_map.resolution),
                   origin_x=float(occupancy_map.origin_x), origin_y=float(occupancy_map.origin_y))

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) of window cells' centres."""
        xs = self.origin_x + (self.col0 + np.asarray(cols) + 0.5) * self.resolution
        ys = self.origin_y + (self.row0 + np.asarray(rows) + 0.5) * self.resolution
        return xs, ys

    def cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Window (row, col) of world points, clipped into the window."""
        cols = np.floor((np.asarray(xs) - self.origin_x) / self.resolution) - self.col0
        rows = np.floor((np.asarray(ys) - self.origin_y) / self.resolution) - self.row0
        height, width = self.metres.shape
        return (np.clip(rows, 0, height - 1).astype(np.intp),
                np.clip(cols, 0, width - 1).astype(np.intp))

    def disc_mask(self, discs: list[KeepClear], *, grow: float = 0.0) -> np.ndarray:
        """Window cells whose centre lies within ``radius + grow`` of a disc's centre."""
        mask = np.zeros(self.metres.shape, dtype=bool)
        for x, y, radius in discs:
            reach = radius + grow
            (r0, r1), (c0, c1) = self.cells(np.array([x - reach, x + reach]),
                                            np.array([y - reach, y + reach]))
            rows, cols = np.mgrid[r0:r1 + 1, c0:c1 + 1]
            xs, ys = self.centres(rows, cols)
            mask[r0:r1 + 1, c0:c1 + 1] |= np.hypot(xs - x, ys - y) <= reach
        return mask

    def line_is_clear(self, start: np.ndarray, end: np.ndarray, walkable: np.ndarray) -> bool:
        """Whether every point of a segment inside the window lies on a ``walkable`` cell."""
        (x0, y0), (x1, y1) = start, end
        samples = math.ceil(math.hypot(x1 - x0, y1 - y0) / (0.5 * self.resolution)) + 1
        t = np.arange(samples) / max(samples - 1, 1)
        cols = ((x0 - self.origin_x + t * (x1 - x0)) / self.resolution).astype(np.intp)
        rows = ((y0 - self.origin_y + t * (y1 - y0)) / self.resolution).astype(np.intp)
        return bool(walkable[rows - self.row0, cols - self.col0].all())

    def lines_are_clear(self, start: np.ndarray, ends: np.ndarray,
                        walkable: np.ndarray) -> np.ndarray:
        """:meth:`line_is_clear` from ``start`` to each of ``ends`` (n, 2), at once.

        Each segment is sampled exactly as :meth:`line_is_clear` samples it (the same count,
        the same arithmetic), so the answers are the same, bit for bit.
        """
        x0, y0 = float(start[0]), float(start[1])
        x1, y1 = ends[:, 0], ends[:, 1]
        lengths = np.array([math.hypot(x - x0, y - y0) for x, y in zip(x1.tolist(),
                                                                        y1.tolist(),
                                                                        strict=True)])
        samples = np.ceil(lengths / (0.5 * self.resolution)).astype(np.intp) + 1
        steps = np.arange(int(samples.max()))
        t = steps[None, :] / np.maximum(samples - 1, 1)[:, None]
        cols = ((x0 - self.origin_x + t * (x1 - x0)[:, None]) / self.resolution).astype(np.intp)
        rows = ((y0 - self.origin_y + t * (y1 - y0)[:, None]) / self.resolution).astype(np.intp)
        inside = steps[None, :] < samples[:, None]
        cols, rows = np.where(inside, cols, cols[:, :1]), np.where(inside, rows, rows[:, :1])
        clear: NDArray[np.bool_] = np.logical_and.reduce(
            walkable[rows - self.row0, cols - self.col0], axis=1)
        return clear


# ----------------------------------------------------------------------------------- idlers
class RobotPassage:
    """Where the robot's centre can go, as connected regions, so idlers never split one.

    Cutting off a pocket of at most :data:`POCKET_M2` (the corner behind an idler by a wall)
    is no split: it strands no target and keeps the original's draw nearly untouched.
    """

    def __init__(self, clearance: Clearance) -> None:
        step = max(1, round(PASSAGE_CELL / clearance.resolution))
        self._step = step
        self._sample = (slice(step // 2, None, step), slice(step // 2, None, step))
        self._clearance = clearance
        self.passable = clearance.metres[self._sample] >= ROBOT_PASSAGE_CLEARANCE
        self.labels, _ = ndimage.label(self.passable)

    def block(self, x: float, y: float) -> bool:
        """Stand a person at (x, y) unless that splits a region; True when they stand there."""
        reach = PERSON_RADIUS + ROBOT_PASSAGE_CLEARANCE
        cut = self._clearance.disc_mask([(x, y, reach)])[self._sample] & self.passable
        after = self.passable & ~cut
        labels, _ = ndimage.label(after)
        pocket = POCKET_M2 / (self._clearance.resolution * self._step) ** 2
        for region in np.unique(self.labels[cut]):
            sizes = np.bincount(labels[(self.labels == region) & after])
            if np.count_nonzero(sizes > pocket) > 1:
                return False
        self.passable, self.labels = after, labels
        return True


def most_idlers(allowed: np.ndarray, resolution: float) -> int:
    """An upper bound on how many idlers ``allowed`` cells hold, :data:`IDLER_SPACING` apart.

    Discs of half the spacing round the idlers do not overlap, and each lies within the allowed
    cells grown by its radius (and a cell and a half, for the grid): their areas add up to no
    more than that grown area's.
    """
    radius = IDLER_SPACING / 2.0
    reach = ndimage.distance_transform_edt(~allowed) * resolution
    grown = float(np.count_nonzero(reach <= radius + 1.5 * resolution)) * resolution ** 2
    return math.floor(grown / (math.pi * radius ** 2))


IdlerPose = tuple[float, float, float]  # (x, y, yaw)


def idler_poses(clearance: Clearance, rng: np.random.Generator, *, count: int,
                areas: tuple[IdlingArea, ...], occupied: list[KeepClear]) -> list[IdlerPose]:
    """Random standing poses, :data:`IDLER_SPACING` apart, off the ``occupied`` discs, splitting
    no passage: in the idling ``areas`` when there are any, else anywhere clear of walls."""
    if count == 0:
        return []
    draw = _area_draw(clearance, areas) if areas else _free_draw(clearance, count)
    passage = RobotPassage(clearance)
    poses: list[IdlerPose] = []
    for _ in range(count * PLACEMENT_DRAWS):
        if len(poses) == count:
            break
        x, y, yaw = draw(rng)
        if any(math.hypot(x - sx, y - sy) < IDLER_SPACING for sx, sy, _ in poses):
            continue
        if any(math.hypot(x - ox, y - oy) < radius + PERSON_RADIUS
               for ox, oy, radius in occupied):
            continue
        if passage.block(x, y):
            poses.append((x, y, yaw))
    if len(poses) < count:
        where = "the world's idling areas" if areas else "this map"
        raise CrowdError(f"room for only {len(poses)} of {count} idlers in {where}")
    return poses


Draw = Callable[[np.random.Generator], IdlerPose]


def _area_draw(clearance: Clearance, areas: tuple[IdlingArea, ...]) -> Draw:
    """The original's draw: an area, a uniform point in it, its yaw ± a half radian; a point on
    a blocked cell is drawn again."""

    def draw(rng: np.random.Generator) -> IdlerPose:
        while True:
            area = areas[int(rng.integers(len(areas)))]
            x = area.min_x + (area.max_x - area.min_x) * float(rng.uniform())
            y = area.min_y + (area.max_y - area.min_y) * float(rng.uniform())
            yaw = area.yaw + float(rng.uniform(-IDLER_YAW_SPREAD, IDLER_YAW_SPREAD))
            row, col = clearance.cells(np.array([x]), np.array([y]))
            if clearance.metres[row[0], col[0]] > 0.0:
                return x, y, yaw

    if not any(_area_has_floor(clearance, area) for area in areas):
        raise CrowdError("no idling area has a free cell for an idler")
    return draw


def _area_has_floor(clearance: Clearance, area: IdlingArea) -> bool:
    step = clearance.resolution / 2.0
    xs = np.arange(area.min_x, area.max_x + step, step)
    ys = np.arange(area.min_y, area.max_y + step, step)
    grid_x, grid_y = np.meshgrid(xs, ys)
    rows, cols = clearance.cells(grid_x.ravel(), grid_y.ravel())
    return bool((clearance.metres[rows, cols] > 0.0).any())


def _free_draw(clearance: Clearance, count: int) -> Draw:
    """Anywhere :data:`IDLER_WALL_CLEARANCE` clear of walls, facing any way."""
    allowed = clearance.metres >= IDLER_WALL_CLEARANCE
    candidates = np.flatnonzero(allowed)
    if candidates.size == 0:
        raise CrowdError("no free spot for idlers: nowhere 0.6 m clear of walls")
    most = most_idlers(allowed, clearance.resolution)
    if count > most:  # drawing spots for them would only take minutes to fail
        raise CrowdError(f"room for only {most} of {count} idlers on this map at best "
                         f"({IDLER_SPACING:g} m apart, {IDLER_WALL_CLEARANCE:g} m from walls)")

    def draw(rng: np.random.Generator) -> IdlerPose:
        row, col = np.unravel_index(candidates[rng.integers(candidates.size)], allowed.shape)
        x, y = (float(v) for v in clearance.centres(row, col))
        return x, y, float(rng.uniform(-math.pi, math.pi))

    return draw


# ----------------------------------------------------------------------------------- routes
def grid_graph(free: np.ndarray, spacing: float) -> coo_matrix:
    """An 8-connected graph of the ``free`` cells (no corner cutting), nodes in row-major order."""
    ids = np.full(free.shape, -1, dtype=np.intp)
    ids[free] = np.arange(int(free.sum()))
    height, width = free.shape
    sources, targets, lengths = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        c0, c1 = max(0, -dc), width - max(0, dc)
        src, dst = ids[:height - dr, c0:c1], ids[dr:, c0 + dc:c1 + dc]
        ok = (src >= 0) & (dst >= 0)
        if dr and dc:
            ok &= free[dr:, c0:c1] & free[:height - dr, c0 + dc:c1 + dc]
        sources.append(src[ok])
        targets.append(dst[ok])
        lengths.append(np.full(int(ok.sum()), spacing * math.hypot(dr, dc)))
    count = int(free.sum())
    return coo_matrix((np.concatenate(lengths), (np.concatenate(sources),
                                                 np.concatenate(targets))), shape=(count, count))


class RouteGrid:
    """Coarse free space for walkers, and looping routes planned on it."""

    def __init__(self, clearance: Clearance, *, keep_clear: list[KeepClear],
                 idlers: list[tuple[float, float]]) -> None:
        self._clearance = clearance
        avoid = clearance.disc_mask(keep_clear, grow=PERSON_RADIUS)
        avoid |= clearance.disc_mask([(x, y, WALKER_IDLER_CLEARANCE) for x, y in idlers])
        self.walkable = (clearance.metres >= WALKER_WALL_CLEARANCE) & ~avoid
        step = max(1, round(ROUTE_CELL / clearance.resolution))
        free = self.walkable[step // 2::step, step // 2::step]
        self.graph = grid_graph(free, spacing=step * clearance.resolution).tocsr()
        rows, cols = np.nonzero(free)  # in node-id order
        xs, ys = clearance.centres(step // 2 + rows * step, step // 2 + cols * step)
        self.points = np.column_stack([xs, ys])
        _, component = connected_components(self.graph, directed=False)
        largest = np.argmax(np.bincount(component)) if component.size else 0
        self.nodes = np.flatnonzero(component == largest)
        if self.nodes.size < 2:
            raise CrowdError("no free space wide enough for walker routes on this map")

    def loop(self, rng: np.random.Generator) -> np.ndarray:
        """A closed polyline (first point repeated last) through a few random waypoints."""
        waypoints = self._waypoints(rng, int(rng.integers(ROUTE_WAYPOINTS[0],
                                                          ROUTE_WAYPOINTS[1] + 1)))
        sources = np.unique(waypoints)
        _, predecessors = dijkstra(self.graph, directed=False, indices=sources,
                                   return_predecessors=True)
        route = [self.points[waypoints[:1]]]
        for start, end in zip(waypoints, [*waypoints[1:], waypoints[0]], strict=True):
            row = predecessors[int(np.searchsorted(sources, start))]
            leg = self._straightened(self.points[[start, *self._leg(row, start, end)]])
            route.append(leg[1:])
        return np.vstack(route)

    def _waypoints(self, rng: np.random.Generator, count: int) -> list[int]:
        chosen = [int(self.nodes[rng.integers(self.nodes.size)])]
        for _ in range(count - 1):
            gaps = np.hypot(*(self.points[self.nodes] - self.points[chosen[-1]]).T)
            far = self.nodes[gaps >= ROUTE_MIN_LEG]
            chosen.append(int(far[rng.integers(far.size)]) if far.size
                          else int(self.nodes[np.argmax(gaps)]))
        return chosen

    @staticmethod
    def _leg(predecessors: np.ndarray, start: int, end: int) -> list[int]:
        """Node ids after ``start`` up to and including ``end``."""
        leg = []
        node = end
        while node != start:
            leg.append(node)
            node = int(predecessors[node])
        return leg[::-1]

    def _straightened(self, points: np.ndarray) -> np.ndarray:
        """The path's ends, and those of its corners that no clear straight line can skip."""
        kept = [0]
        while kept[-1] < len(points) - 1:
            here = kept[-1]
            kept.append(here + 1 + self._clear_run(points, here))
        return points[kept]

    def _clear_run(self, points: np.ndarray, here: int) -> int:
        """How many of the points after ``here`` + 1, in order, a clear line from ``here``
        reaches before the first it does not; checked :data:`LINES_AT_ONCE` at a time."""
        run = 0
        for first in range(here + 2, len(points), LINES_AT_ONCE):
            clear = self._clearance.lines_are_clear(
                points[here], points[first:first + LINES_AT_ONCE], self.walkable)
            blocked = np.flatnonzero(~clear)
            if blocked.size:
                return run + int(blocked[0])
            run += clear.size
        return run


def route_meets(route: np.ndarray, standing: np.ndarray) -> bool:
    """Whether a walker on the closed polyline ``route`` would ever have one of the
    ``standing`` points (n, 2) in its lane, walking either way along it.

    Along a leg the lane's sideways offset of a point is constant, and the point lies ahead
    within the stop distance for some position on the leg exactly when the leg reaches to
    within that distance behind it.
    """
    if standing.size == 0:
        return False
    for start, end in itertools.pairwise(route):
        length = float(math.hypot(*(end - start)))
        if length == 0.0:
            continue
        along_unit = (end - start) / length
        offset = standing - start
        ahead = offset @ along_unit
        side = np.abs(offset[:, 0] * along_unit[1] - offset[:, 1] * along_unit[0])
        reach = np.sqrt(np.clip(WALKER_STOP_DISTANCE ** 2 - side ** 2, 0.0, None))
        in_band = side < WALKER_LANE_HALF_WIDTH
        forwards = (ahead > 0.0) & (ahead - reach < length)
        backwards = (ahead < length) & (ahead + reach > 0.0)
        if (in_band & (forwards | backwards)).any():
            return True
    return False


# ----------------------------------------------------------------------------------- walkers
@overload
def in_stop_lane(dx: float, dy: float, cos: float, sin: float, *,
                 below: float = 0.0) -> bool: ...
@overload
def in_stop_lane(dx: NDArray[np.float64], dy: NDArray[np.float64], cos: NDArray[np.float64],
                 sin: NDArray[np.float64], *,
                 below: float | NDArray[np.float64] = 0.0) -> NDArray[np.bool_]: ...
def in_stop_lane(dx: Any, dy: Any, cos: Any, sin: Any, *, below: Any = 0.0) -> Any:
    """Whether a point (dx, dy) from a walker facing (cos, sin) stops it: nearer than
    :data:`WALKER_STOP_DISTANCE` in 3-D (the point's origin ``below`` metres under the
    walker's), ahead of the walker and within :data:`WALKER_LANE_HALF_WIDTH` of its line (the
    walker's own position is never ahead of it). Floats or arrays, element by element (each
    product, sum and difference rounded alike by Python and numpy, so the same answers bit for
    bit): the walking step (:meth:`Walker.first_blocking`) and the playability check
    (:meth:`Walker.stops_for_good`) share the rule."""
    reach = lane_reach(below)
    return ((dx * dx + dy * dy < reach) & (dx * cos + dy * sin > 0.0)
            & (abs(dy * cos - dx * sin) < WALKER_LANE_HALF_WIDTH))


@overload
def lane_reach(below: float) -> float: ...
@overload
def lane_reach(below: NDArray[np.float64]) -> NDArray[np.float64]: ...
def lane_reach(below: Any) -> Any:
    """The square of the stop distance in the plane for a point whose origin lies ``below``
    metres under the walker's (:func:`in_stop_lane`)."""
    return WALKER_STOP_DISTANCE * WALKER_STOP_DISTANCE - below * below


FLOOR_REACH = lane_reach(0.0)
"""The :func:`lane_reach` of a person on the floor, as a walker is."""
ROBOT_REACH = lane_reach(ROBOT_BELOW_WALKER)
"""The :func:`lane_reach` of the robot."""
BY_WALKERS = 3
"""Where the other walkers come in the groups :meth:`Crowd.step` tests a walker's lane
against (after the robot, the guest and the idlers near its leg)."""


def standing_near_legs(route: NDArray[np.float64], standing: Sequence[tuple[float, float]]
                       ) -> list[tuple[tuple[float, float], ...]]:
    """For each leg of the polyline ``route``, the ``standing`` points that can be in the lane
    of a walker somewhere on that leg: those within :data:`WALKER_STOP_DISTANCE` of the leg,
    and a margin over rounding (a walker stands on its leg, and a farther point is never
    within its stop distance)."""
    legs = len(route) - 1
    if not standing:
        return [() for _ in range(legs)]
    points = np.asarray(standing, dtype=np.float64)
    starts, spans = route[:-1], np.diff(route, axis=0)
    squares = np.maximum(np.einsum("ld,ld->l", spans, spans), 1e-300)
    offsets = points[None, :, :] - starts[:, None, :]
    along = np.clip(np.einsum("lnd,ld->ln", offsets, spans) / squares[:, None], 0.0, 1.0)
    gaps = np.hypot(*np.moveaxis(offsets - along[:, :, None] * spans[:, None, :], 2, 0))
    near = gaps < WALKER_STOP_DISTANCE + STANDING_SLACK
    return [tuple(standing[index] for index in np.flatnonzero(row).tolist()) for row in near]


def facing(heading: float, *, forwards: bool) -> tuple[float, float, float]:
    """(yaw, cos yaw, sin yaw) of a walker on a leg of the given heading, walking it forwards
    or backwards (the reverse heading as atan2 gives it)."""
    yaw = heading if forwards else math.atan2(-math.sin(heading), -math.cos(heading))
    return yaw, math.cos(yaw), math.sin(yaw)


@dataclass
class Walker:
    """A person walking a closed polyline at a constant speed."""

    person: Person
    route: np.ndarray  # (n, 2), first point repeated last
    along: np.ndarray  # arc length at each route point
    speed: float
    travelled: float  # arc length from the route's start, below the route's length
    direction: int = 1  # +1 along the route, -1 back along it
    waited: float = 0.0  # sim seconds stopped, this time

    def __post_init__(self) -> None:
        # advance() runs for every walker every other physics step: plain floats and bisect
        # there, not numpy scalars (a tenth of the cost per call)
        self._xs = [float(x) for x in self.route[:, 0]]
        self._ys = [float(y) for y in self.route[:, 1]]
        self._along = [float(a) for a in self.along]
        headings = [math.atan2(y1 - y0, x1 - x0) for x0, y0, x1, y1 in zip(
            self._xs, self._ys, self._xs[1:], self._ys[1:], strict=False)]
        # (yaw, cos, sin) per leg, walking forwards and backwards: worked out once, not per step
        self._facings = {forwards: [facing(heading, forwards=forwards) for heading in headings]
                         for forwards in (True, False)}
        self._leg = 0  # the leg it is on, where advance() looks first
        self._cos, self._sin = 1.0, 0.0  # of the way it faces; advance() keeps them

    @classmethod
    def on(cls, person: Person, route: np.ndarray, *, speed: float,
           start: float) -> Walker:
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(route, axis=0).T))])
        if not along[-1] > 0.0:
            raise ValueError(f"{person.name}: a walker's route needs some length")
        walker = cls(person=person, route=route, along=along, speed=speed, travelled=0.0)
        walker.advance(start * along[-1])
        return walker

    def advance(self, metres: float) -> None:
        """Walk ``metres`` along the route (back along it when negative), looping round."""
        along = self._along
        travelled = self.travelled = (self.travelled + metres) % along[-1]
        leg = self._leg
        if not along[leg] <= travelled < along[leg + 1]:  # else still the leg bisect would find
            leg = self._leg = min(bisect.bisect_right(along, travelled) - 1, len(along) - 2)
        t = (travelled - along[leg]) / (along[leg + 1] - along[leg])
        xs, ys = self._xs, self._ys
        self.person.x = xs[leg] + t * (xs[leg + 1] - xs[leg])
        self.person.y = ys[leg] + t * (ys[leg + 1] - ys[leg])
        self.person.yaw, self._cos, self._sin = self._facings[self.direction > 0][leg]

    @property
    def facing_unit(self) -> tuple[float, float]:
        """(cos, sin) of the way it faces (its yaw's)."""
        return self._cos, self._sin

    def turn_back(self) -> None:
        """Walk the route the other way from here (blocked for longer than its patience)."""
        self.direction = -self.direction
        self.waited = 0.0
        self.advance(0.0)

    @property
    def leg(self) -> int:
        """The leg of the route it stands on (route points ``leg`` to ``leg + 1``)."""
        return self._leg

    def blocked(self, points: Iterable[tuple[float, float]], *, below: float = 0.0) -> bool:
        """Whether any point lies in the lane ahead (:func:`in_stop_lane`)."""
        return self.first_blocking(((points, lane_reach(below)),)) is not None

    def first_blocking(self, groups: Iterable[tuple[Iterable[tuple[float, float]], float]]
                       ) -> int | None:
        """The index of the first of ``groups`` (points, and the :func:`lane_reach` of their
        height under the walker) with a point in the lane ahead, or None: :func:`in_stop_lane`
        with its arithmetic, in plain floats, for the points within :data:`LANE_WINDOW_M`
        along x (no farther one is within the stop distance)."""
        x, y, cos, sin = self.person.x, self.person.y, self._cos, self._sin
        low, high = x - LANE_WINDOW_M, x + LANE_WINDOW_M
        for index, (points, reach) in enumerate(groups):
            for px, py in points:
                if low < px < high:
                    dx, dy = px - x, py - y
                    if (dx * dx + dy * dy < reach and dx * cos + dy * sin > 0.0
                            and abs(dy * cos - dx * sin) < WALKER_LANE_HALF_WIDTH):
                        return index
        return None

    def stops_for_good(self, still: NDArray[np.float64], *, after_m: float = 0.0
                       ) -> tuple[float, float, float] | None:
        """Where this walker, walking on from here, first has one of ``still`` (n, 2: people
        who never move) in its lane, and so stands for good, as (metres walked to get there,
        x, y); None when its loop passes them all. ``after_m``: look from that many metres on
        (a lap from there).

        The loop is sampled every :data:`STOP_SEARCH_STEP` metres, each sample facing the way
        :meth:`advance` faces the walker there; the lane is :meth:`blocked`'s.
        """
        if still.size == 0:
            return None
        steps = after_m + np.arange(0.0, float(self.along[-1]), STOP_SEARCH_STEP)
        xs, ys, cos, sin = self._poses_after(steps)
        hits = in_stop_lane(still[None, :, 0] - xs[:, None], still[None, :, 1] - ys[:, None],
                            cos[:, None], sin[:, None]).any(axis=1)
        if not hits.any():
            return None
        first = int(np.argmax(hits))
        return float(steps[first]), float(xs[first]), float(ys[first])

    def pose_after(self, metres: float) -> tuple[float, float, float, float]:
        """(x, y, cos, sin) where the walker is, and the way it faces, once it has walked
        ``metres`` on from here."""
        xs, ys, cos, sin = self._poses_after(np.array([metres]))
        return float(xs[0]), float(ys[0]), float(cos[0]), float(sin[0])

    def _poses_after(self, steps: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        along = self.along
        spots = (self.travelled + self.direction * steps) % float(along[-1])
        legs = np.clip(np.searchsorted(along, spots, side="right") - 1, 0, len(along) - 2)
        t = (spots - along[legs]) / (along[legs + 1] - along[legs])
        xs = self.route[legs, 0] + t * (self.route[legs + 1, 0] - self.route[legs, 0])
        ys = self.route[legs, 1] + t * (self.route[legs + 1, 1] - self.route[legs, 1])
        ways = np.array([(cos, sin) for _, cos, sin in self._facings[self.direction > 0]])
        return xs, ys, ways[legs, 0], ways[legs, 1]


# ------------------------------------------------------------------------------------ crowd
def walkers_on_routes(names: list[str], routes: tuple[WalkerRoute, ...],
                      rng: np.random.Generator, *, placed: tuple[PlacedWalker, ...] = (),
                      occupied: Sequence[KeepClear] = ()) -> list[Walker]:
    """One walker per name on the world's loops, drawn as the original's generator drew them
    (see the module docstring), or as ``placed`` names them; no two start at one waypoint,
    and a drawn walker starts at none within its stop distance of an ``occupied`` spot (a
    random task's robot or guest: the original's fixed spots had no walker start on them)."""
    by_name = {route.name: route for route in routes}
    entries = [route for route in routes for _ in range(route.weight)]
    starts: set[tuple[float, float]] = set()
    walkers = []
    for index, name in enumerate(names):
        if placed:
            fixed = placed[index]
            route, first, speed = by_name[fixed.route], fixed.start, fixed.speed
        else:
            route = entries[int(rng.integers(len(entries)))]
            speed = float(rng.uniform(*WALKER_SPEED_RANGE))
            first = _free_start(route, int(rng.integers(FIRST_WAYPOINT_DRAW)),
                                taken=starts, occupied=occupied)
        starts.add(route.waypoints[first])
        loop = route.waypoints[first:] + route.waypoints[:first + 1]
        x, y = loop[0]
        person = Person(name=name, role=WALKER, x=x, y=y, yaw=0.0)
        walkers.append(Walker.on(person, np.array(loop, dtype=float), speed=speed, start=0.0))
    return walkers


def _free_start(route: WalkerRoute, draw: int, *, taken: set[tuple[float, float]],
                occupied: Sequence[KeepClear]) -> int:
    """The waypoint ``draw`` round the loop, or the next one free to start at."""
    count = len(route.waypoints)
    for step in range(count):
        first = (draw + step) % count
        x, y = route.waypoints[first]
        if (route.waypoints[first] not in taken
                and all(math.hypot(x - ox, y - oy) >= WALKER_STOP_DISTANCE + radius
                        for ox, oy, radius in occupied)):
            return first
    raise WalkerStartError(f"walker route {route.name!r}: no waypoint is free to start a "
                           f"walker at")


def fresh_names(rng: np.random.Generator, count: int, *, taken: set[str]) -> list[str]:
    """``count`` distinct ``human_NNNNN`` names, none of them in ``taken``."""
    names: list[str] = []
    used = set(taken)
    while len(names) < count:
        name = f"human_{int(rng.integers(0, 100_000)):05d}"
        if name not in used:
            used.add(name)
            names.append(name)
    return names


def _queued(walker: Walker, holder: Walker, spot: NDArray[np.float64],
            arrival_s: float) -> tuple[float, float, float] | None:
    """Where ``walker`` stands for good behind ``holder``, who stands at ``spot`` from
    ``arrival_s`` on (as :meth:`Walker.stops_for_good`). A walker whose lane meets the spot
    before then has walked past it, unless the holder, on its way there, is ahead in its lane
    at that moment (it follows the holder, and queues); it then meets them a lap on."""
    stop = walker.stops_for_good(spot)
    if stop is None or stop[0] >= arrival_s * walker.speed:
        return stop
    x, y, cos, sin = walker.pose_after(stop[0])
    hx, hy, _, _ = holder.pose_after(stop[0] / walker.speed * holder.speed)
    if in_stop_lane(hx - x, hy - y, cos, sin):
        return stop
    return walker.stops_for_good(spot, after_m=arrival_s * walker.speed)


class Crowd:
    """All walkers and idlers of one run.

    ``keep_clear`` discs keep walker routes away (the task's spots and areas); ``occupied``
    discs are bodies nobody may be placed on (the guest, the robot's start); ``idling_areas``
    are where idlers stand (none: anywhere free). ``routes`` are the world's walker loops (none:
    random loops) and ``placed`` the walkers on them a fixed task names (none: drawn). A walker
    blocked by the robot, the guest or an idler for ``walker_patience_s`` turns back; the
    default, infinity, is the original's rule: it waits as long as it stays blocked.
    """

    def __init__(self, occupancy_map: OccupancyMap, *, rng: np.random.Generator,
                 walkers: int, idlers: int, taken_names: set[str],
                 keep_clear: list[KeepClear], occupied: Sequence[KeepClear] = (),
                 idling_areas: tuple[IdlingArea, ...] = (),
                 walker_patience_s: float = math.inf,
                 routes: tuple[WalkerRoute, ...] = (),
                 placed: tuple[PlacedWalker, ...] = ()) -> None:
        if walkers < 0 or idlers < 0:
            raise ValueError(f"walkers {walkers}, idlers {idlers}: counts must be 0 or more")
        if walkers + idlers + len(taken_names) > NAME_NUMBERS:
            raise CrowdError(f"walkers {walkers} and idlers {idlers}: more people than the "
                             f"{NAME_NUMBERS} human_NNNNN names")
        self.walker_patience_s = walker_patience_s
        # walkers on the world's one-way loops wait for each other as the original's did, as
        # long as they stay blocked; random loops meet head-on, so there a standoff ends
        self.standoff_s = math.inf if routes else WALKER_STANDOFF_S
        clearance = Clearance.of(occupancy_map)
        names = fresh_names(rng, walkers + idlers, taken=taken_names)
        poses = idler_poses(clearance, rng, count=idlers, areas=idling_areas,
                            occupied=list(occupied))
        standing = [Person(name=name, role=IDLER, x=x, y=y, yaw=yaw)
                    for name, (x, y, yaw) in zip(names[walkers:], poses, strict=True)]
        self._walkers: list[Walker] = []
        # on the world's routes idlers may stand in a lane, and stop walkers as anyone does
        self._standing = [(x, y) for x, y, _ in poses] if routes else []
        if walkers and routes:
            self._walkers = walkers_on_routes(names[:walkers], routes, rng, placed=placed,
                                              occupied=occupied)
        elif walkers:
            spots = [(x, y) for x, y, _ in poses]
            grid = RouteGrid(clearance, keep_clear=keep_clear, idlers=spots)
            still = np.array(spots + [(x, y) for x, y, _ in occupied], dtype=float)
            self._walkers = [self._walker(name, grid, rng, still.reshape(-1, 2))
                             for name in names[:walkers]]
        self.people: list[Person] = [w.person for w in self._walkers] + standing
        self._standing_near = [standing_near_legs(walker.route, self._standing)
                               for walker in self._walkers]

    @staticmethod
    def _walker(name: str, grid: RouteGrid, rng: np.random.Generator,
                still: np.ndarray) -> Walker:
        for _ in range(ROUTE_DRAWS):
            route = grid.loop(rng)
            if not route_meets(route, still):
                break
        else:
            raise CrowdError(f"no walker route clear of the idlers in {ROUTE_DRAWS} draws")
        speed = float(rng.uniform(*WALKER_SPEED_RANGE))
        person = Person(name=name, role=WALKER, x=float(route[0, 0]), y=float(route[0, 1]),
                        yaw=0.0)
        return Walker.on(person, route, speed=speed, start=float(rng.uniform()))

    @property
    def walkers(self) -> list[Walker]:
        return list(self._walkers)

    def step(self, dt: float, *, robot: tuple[float, float, float],
             others: Sequence[tuple[float, float]] = ()) -> None:
        """Move every walker ``dt`` seconds on, except those with someone in their lane (as
        everyone stood at the step's start): the robot, ``others`` (the guest), an idler or
        another walker. A walker waits for the first three for :attr:`walker_patience_s`, and
        for walkers alone :attr:`standoff_s`; then it turns back.

        Each walker's lane is tested against the robot, ``others``, the idlers near the leg
        it is on (:func:`standing_near_legs`, worked out once) and the other walkers, in that
        order (:meth:`Walker.first_blocking`)."""
        if dt < 0.0:
            raise ValueError(f"dt {dt}: must be 0 or more")
        walkers = self._walkers
        if not walkers:
            return
        robot_place = (((robot[0], robot[1]),), ROBOT_REACH)
        others_near = (others, FLOOR_REACH)
        # last, as BY_WALKERS says; a walker's own place never stops it
        walking = ([(walker.person.x, walker.person.y) for walker in walkers], FLOOR_REACH)
        blocks = [walker.first_blocking((robot_place, others_near,
                                         (near_legs[walker.leg], FLOOR_REACH), walking))
                  for walker, near_legs in zip(walkers, self._standing_near, strict=True)]
        for walker, block in zip(walkers, blocks, strict=True):
            if block is None:
                walker.waited = 0.0
                walker.advance(walker.direction * walker.speed * dt)
                continue
            walker.waited += dt
            patience = self.standoff_s if block == BY_WALKERS else self.walker_patience_s
            if walker.waited >= patience:
                walker.turn_back()

    def held_for_good(self, *, others: Sequence[tuple[float, float]] = ()
                      ) -> list[tuple[float, float]]:
        """Where walkers will stand for good, held by someone who never moves: an idler (on
        the world's routes) or ``others`` (the guest waiting to be picked up), or, where
        walkers wait for each other for ever, a walker held so (a queue behind it).

        Each walker is taken to walk on from its start at its speed, the robot and the moving
        walkers aside, and to stop at the first such person in its lane. The walker that gets
        to its stop first is held there; the others are looked at again with it standing
        (each where it comes along once it stands there: :func:`_queued`), until none is held.
        None when walkers turn back from the people who block them.
        """
        if not math.isinf(self.walker_patience_s):
            return []
        still = [*self._standing, *others]
        if not math.isinf(self.standoff_s):  # walkers turn back from a held walker: no queue
            points = np.array(still, dtype=float).reshape(-1, 2)
            return [(x, y) for _, x, y in filter(None, (walker.stops_for_good(points)
                                                        for walker in self._walkers))]
        held: list[tuple[float, float]] = []
        waiting = list(self._walkers)
        points = np.array(still, dtype=float).reshape(-1, 2)
        stops = [walker.stops_for_good(points) for walker in waiting]
        while True:
            arrivals = [(stop[0] / walker.speed, index, stop[1], stop[2])
                        for index, (walker, stop) in enumerate(zip(waiting, stops, strict=True))
                        if stop is not None]
            if not arrivals:
                return held
            arrival, first, x, y = min(arrivals)
            holder = waiting.pop(first)
            del stops[first]
            held.append((x, y))
            # the first stop among more people: the earlier of the old one and the new one's
            spot = np.array([[x, y]])
            stops = [min(filter(None, (stop, _queued(walker, holder, spot, arrival))),
                         default=None) for walker, stop in zip(waiting, stops, strict=True)]

    def states(self) -> list[tuple[str, str, float, float]]:
        """(name, role, x, y) of everybody, walkers first."""
        return [(p.name, p.role, p.x, p.y) for p in self.people]
