"""Where to look for the guest: exploration waypoints around the pick-up area, and a search
around the spot where a guest who was being guided was last heard.

RFID names the guest only within 2.0 m of the robot, so a search is a set of waypoints whose
RFID discs cover where the guest may stand, visited in an order that looks near first.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from bt_servicesim.planning.geometry import Box, Point, Pose2D
from bt_servicesim.planning.goals import PERSON_CLEARANCE, ROBOT_CLEARANCE, distance_to_box
from bt_servicesim.planning.occupancy import OccupancyGrid2D, Window
from bt_servicesim.planning.rules import (
    FOLLOW_GAP,
    RFID_RANGE,
)

EXPLORATION_REACH = 6.0
"""How far around the pick-up box a search for the guest reaches."""


WAYPOINT_SPACING = 2.4
"""Search lattice spacing: the square of 2.4 m has a half-diagonal of 1.70 m, inside RFID range."""


COVER_RADIUS = 1.8


#: Exploration visits the waypoints around the box in bands this wide, nearest band first.
SEARCH_BAND = 2.0
"""A waypoint counts as covering cells this close (RFID range less some goal tolerance)."""


SNAP_RADIUS = 1.0
"""How far a search waypoint may be moved to land on a reachable cell."""


SEARCH_RINGS = (WAYPOINT_SPACING, 2.0 * WAYPOINT_SPACING)
"""Radii of the rings searched around the spot where a lost guest was last seen."""


def exploration_waypoints(box: Box, grid: OccupancyGrid2D, robot: Pose2D) -> list[Pose2D]:
    """Waypoints whose RFID discs cover the box and the open space within 6 m of it.

    A square lattice with :data:`WAYPOINT_SPACING` centred on the box, each point moved to the
    nearest cell the robot can reach (within 1 m, else dropped); then a repair pass, while some
    target is uncovered, adds the reachable spot covering the most uncovered targets among
    those that cover it. The targets are the cells within :data:`EXPLORATION_REACH` of the box
    where a person could stand, connected to the robot's open space (not beyond closed walls
    or outside the building); each ends within :data:`COVER_RADIUS` of a waypoint, or within
    RFID range where walls keep the robot farther off (targets out of RFID range of anywhere
    reachable cannot be searched and are skipped). Ordered box first — the waypoints covering
    the box, as a nearest-neighbour tour from the robot — then the rest in bands of
    :data:`SEARCH_BAND` metres outward from the box, each band a tour continuing the last: a
    guest placed off the area stands near it, and one nearest-neighbour tour over everything
    could wander 6 m off on one side before looking just beside the box on the other.
    Each yaw is the heading of travel.
    """
    reach = EXPLORATION_REACH + RFID_RANGE
    window = grid.window(box.min_x - reach, box.min_y - reach, box.max_x + reach, box.max_y + reach)
    reachable = grid.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)[window.rows, window.cols]
    if window.is_empty or not reachable.any():
        return []
    open_space = grid.reachable_from(robot.x, robot.y, PERSON_CLEARANCE)
    coverage = _Coverage(box, grid, window, reachable, open_space[window.rows, window.cols])
    for spot in _lattice(box, EXPLORATION_REACH):
        coverage.add_near(spot)
    coverage.repair()
    def band(point: Point) -> int:
        beyond = distance_to_box(box, *point) - COVER_RADIUS
        return 0 if beyond <= 0.0 else 1 + int(beyond // SEARCH_BAND)

    return _tour(robot, coverage.waypoints, band=band)


def _lattice(box: Box, reach: float) -> list[Point]:
    """Points WAYPOINT_SPACING apart, centred on the box, within ``reach`` of it."""
    cx, cy = box.centre
    half = max(box.max_x - box.min_x, box.max_y - box.min_y) / 2.0 + reach
    steps = int(half / WAYPOINT_SPACING) + 1
    points = [(cx + i * WAYPOINT_SPACING, cy + j * WAYPOINT_SPACING)
              for i in range(-steps, steps + 1) for j in range(-steps, steps + 1)]
    return [p for p in points if distance_to_box(box, *p) <= reach]


class _Coverage:
    """Which cells near the box the chosen waypoints cover, in one window of the map.

    The targets are the cells within reach of the box where a person could stand
    (:data:`PERSON_CLEARANCE`) in the open space connected to the robot, and within RFID range
    of a cell the robot can reach. A target counts as covered within :data:`COVER_RADIUS` of a
    waypoint, or within RFID range if the robot cannot get that close to it at all.
    """

    def __init__(self, box: Box, grid: OccupancyGrid2D, window: Window, reachable: np.ndarray,
                 open_space: np.ndarray) -> None:
        self.grid, self.window, self.reachable = grid, window, reachable
        self.xs, self.ys = np.meshgrid(window.xs, window.ys)
        from scipy import ndimage  # when computing, as planning.occupancy says why

        cells, nearest = ndimage.distance_transform_edt(~reachable, return_indices=True)
        gap = cells * grid.resolution  # metres to the nearest reachable cell
        self.gap, (self.nearest_rows, self.nearest_cols) = gap, nearest
        near_box = distance_to_box(box, self.xs, self.ys) <= EXPLORATION_REACH
        self.targets = open_space & near_box & (gap <= RFID_RANGE)
        self.needed = np.where(gap <= COVER_RADIUS, COVER_RADIUS, RFID_RANGE) + 1e-6
        self.to_waypoint = np.full(self.xs.shape, np.inf)
        self.waypoints: list[Point] = []

    def add_near(self, point: Point) -> None:
        """Add the reachable cell nearest ``point`` (within SNAP_RADIUS) if it covers anything."""
        cell = self.grid.world_to_cell(*point)
        row, col = cell.row - self.window.rows.start, cell.col - self.window.cols.start
        if not (0 <= row < self.xs.shape[0] and 0 <= col < self.xs.shape[1]):
            return
        if self.gap[row, col] > SNAP_RADIUS:
            return
        spot = self._nearest_reachable(row, col)
        if any(math.dist(spot, other) < 0.5 for other in self.waypoints):
            return
        disc, distances = self._disc(spot)
        if (self.targets[disc] & (distances <= self.needed[disc])).any():
            self._add(spot)

    def repair(self) -> None:
        """Add waypoints until every target is covered: each time, among the reachable spots
        that cover the first uncovered target, the one covering most uncovered targets."""
        for _round in range(self.targets.size):
            uncovered = self.targets & (self.to_waypoint > self.needed)
            first = np.argwhere(uncovered)
            if first.size == 0:
                return
            self._add(self._best_cover(int(first[0][0]), int(first[0][1]), uncovered))

    def _best_cover(self, row: int, col: int, uncovered: np.ndarray) -> Point:
        """Of the reachable spots (0.15 m lattice) covering target (row, col), the one that
        covers most uncovered targets; the nearest reachable cell is always a candidate."""
        span = math.ceil(2.0 * RFID_RANGE / self.grid.resolution)
        rows = slice(max(row - span, 0), row + span + 1)
        cols = slice(max(col - span, 0), col + span + 1)
        xs, ys = self.xs[rows, cols], self.ys[rows, cols]
        in_reach = np.hypot(xs - self.xs[row, col], ys - self.ys[row, col]) <= self.needed[row, col]
        spots = np.argwhere((self.reachable[rows, cols] & in_reach)[::3, ::3]) * 3
        spots_x = np.append(xs[spots[:, 0], spots[:, 1]], self._nearest_reachable(row, col)[0])
        spots_y = np.append(ys[spots[:, 0], spots[:, 1]], self._nearest_reachable(row, col)[1])
        open_cells = uncovered[rows, cols]
        ox, oy, needed = xs[open_cells], ys[open_cells], self.needed[rows, cols][open_cells]
        reached = np.hypot(spots_x[:, None] - ox[None, :], spots_y[:, None] - oy[None, :])
        best = int(np.argmax((reached <= needed[None, :]).sum(axis=1)))
        return (float(spots_x[best]), float(spots_y[best]))

    def _nearest_reachable(self, row: int, col: int) -> Point:
        r, c = self.nearest_rows[row, col], self.nearest_cols[row, col]
        return (float(self.xs[r, c]), float(self.ys[r, c]))

    def _disc(self, spot: Point) -> tuple[tuple[slice, slice], np.ndarray]:
        """The part of the window within RFID range of ``spot``, and the distances there."""
        cell = self.grid.world_to_cell(*spot)
        row, col = cell.row - self.window.rows.start, cell.col - self.window.cols.start
        span = math.ceil(RFID_RANGE / self.grid.resolution) + 1
        disc = (slice(max(row - span, 0), row + span + 1),
                slice(max(col - span, 0), col + span + 1))
        return disc, np.hypot(self.xs[disc] - spot[0], self.ys[disc] - spot[1])

    def _add(self, spot: Point) -> None:
        self.waypoints.append(spot)
        disc, distances = self._disc(spot)
        np.minimum(self.to_waypoint[disc], distances, out=self.to_waypoint[disc])


def _tour(start: Pose2D, points: list[Point], band: Callable[[Point], int]) -> list[Pose2D]:
    """Nearest-neighbour tour from ``start`` over each band of points in turn, lowest first."""
    tour: list[Pose2D] = []
    here = (start.x, start.y)
    for number in sorted({band(p) for p in points}):
        remaining = [p for p in points if band(p) == number]
        while remaining:
            following = min(remaining, key=lambda p: math.dist(here, p))
            remaining.remove(following)
            yaw = math.atan2(following[1] - here[1], following[0] - here[0])
            tour.append(Pose2D(following[0], following[1], yaw))
            here = following
    return tour


def guest_search_waypoints(
    last_seen: Pose2D, grid: OccupancyGrid2D, robot: Pose2D
) -> list[Pose2D]:
    """For a guest lost while guided: back along the robot's trail, the last-seen spot, then
    rings around it.

    ``last_seen`` is where the robot stood, heading on, when the guest last answered on RFID;
    a guest who stopped (a drift) or fell behind stands behind that pose, on the trail the robot
    drove, about :data:`FOLLOW_GAP` back. So the first waypoint lies that far back along the
    pose's heading (when the robot can reach it). Rings of :data:`SEARCH_RINGS` radii with
    points about :data:`WAYPOINT_SPACING` apart, each
    ring starting on the robot's side and going round; every point is moved to the nearest cell
    the robot can reach (within 1 m) or dropped, as are points within 1.2 m of an earlier one.
    Empty if the robot can reach nothing near the last-seen spot.
    """
    reachable = grid.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)
    centre = grid.nearest_free(last_seen.x, last_seen.y, clearance=ROBOT_CLEARANCE,
                               max_radius=RFID_RANGE, within=reachable)
    if centre is None:
        return []
    behind = grid.nearest_free(last_seen.x - FOLLOW_GAP * math.cos(last_seen.yaw),
                               last_seen.y - FOLLOW_GAP * math.sin(last_seen.yaw),
                               clearance=ROBOT_CLEARANCE, max_radius=0.5, within=reachable)
    points = [behind, centre] if behind is not None else [centre]
    towards_robot = math.atan2(robot.y - centre[1], robot.x - centre[0])
    for radius in SEARCH_RINGS:
        count = math.ceil(2.0 * math.pi * radius / WAYPOINT_SPACING)
        for k in range(count):
            angle = towards_robot + 2.0 * math.pi * k / count
            spot = grid.nearest_free(centre[0] + radius * math.cos(angle),
                                     centre[1] + radius * math.sin(angle),
                                     clearance=ROBOT_CLEARANCE, max_radius=SNAP_RADIUS,
                                     within=reachable)
            if spot is not None and all(math.dist(spot, p) >= FOLLOW_GAP for p in points):
                points.append(spot)
    return _headed((robot.x, robot.y), points)


def _headed(previous: Point, points: list[Point]) -> list[Pose2D]:
    """Poses for ``points`` in order, each facing the way from the point before it."""
    poses = []
    for point in points:
        poses.append(Pose2D(point[0], point[1],
                            math.atan2(point[1] - previous[1], point[0] - previous[0])))
        previous = point
    return poses
