"""Where the robot steps aside for people it cannot pass.

The office's walkers stop while anyone stands in a lane ahead of them (1.5 m ahead, 0.6 m either
side) and wait as long as it stays blocked (the original's ``TrajectoryActorPlugin``);
navigation, for its part, waits for a person to clear its path. A walker coming down a corridor
the robot goes up therefore blocks the robot for good, and so does a pair of walkers either side
of it: the robot's navigation aborts ("no path", "no progress"), and trying the same goal again
meets the same walkers standing in the same places. Someone has to give way, and walkers do not.
The original's walkers use the same corridors (its ``trajectory_private_d`` loop runs along the
office's top corridor), so this is a situation of the competition, not of our simulator.

:func:`give_way_spot` picks where the robot waits instead: the nearest spot by route that the
robot reaches without going on towards the blocked way (the people it sees there are obstacles;
seeing nobody, it takes a disc ahead of it for a wall), that has room around it, and that lies
off every lane the robot can tell people use:

* the passage the robot stands in: the line through the robot along the passage's longest free
  span (a corridor's axis), which is where walkers come down;
* the robot's own recent trail: the walker it met walks on the way the robot came;
* the doorway the route to the spot passes, if it passes one: a walker bound through that door
  walks straight in along its axis, so the spot keeps off that line.

A guest who follows walks the robot's route to the spot and stops a following gap short of it.
Where that is a doorway, the guest shuts the robot in: a walker bound through the same door waits
for the guest, the guest for the robot, and the robot's way back out runs through the guest. So
with a guest in tow the spot lies a following gap further off the lanes, and far enough into open
space that the guest stops off the door's line with room to pass them (:data:`GUEST_STOP_ROOM`).

Walkers' routes are not known to the robot: a walker may be bound for the very room the robot
waits in, and a walker that stops at a corner of its route faces the way it will go, not the way
it came. So the lanes alone guess. What settles it is where people stand, which the robot knows
from navigation's costmap (:mod:`bt_servicesim.planning.people`): the spot, and where a guest in
tow stops, keep far enough from everyone standing near that no walker is held up by them,
whichever way it is bound, and no route to the spot runs through anyone. The mission tries
again (and gives way again, from where everyone then stands) when it stays blocked.

The same spot serves a robot that is about to stand still of its own accord (to look round for
a lost guest): a walker stands for anyone in its lane, so a robot that stands within a lane's
length of someone (:func:`people_held_up`) may hold them there for as long as it stands. It
steps to a spot off the lanes, clear of them, first. And a robot that has stood on its way
(:class:`Standstill`) with someone that near (:func:`held_up_on_costmap`) is in a standoff: it
gives way then rather than wait for its navigation to give up.

Pure: numpy and the occupancy grid, no ROS, no py_trees; a tick computes it once per recovery.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.goals import ROBOT_CLEARANCE
from bt_servicesim.planning.occupancy import OccupancyGrid2D, RouteTree
from bt_servicesim.planning.people import Costmap2D, people_on_costmap
from bt_servicesim.planning.rules import (
    FOLLOW_GAP,
    PEOPLE_LANE_HALF_WIDTH,
    PEOPLE_LANE_LENGTH,
    ROBOT_FOOTPRINT,
)

__all__ = [
    "GIVE_WAY_OFFSET",
    "GUEST_STOP_ROOM",
    "HOLD_UP_REACH",
    "PEOPLE_CLEAR",
    "PEOPLE_REACH",
    "PERSON_BODY",
    "STANDING_STILL",
    "Doorway",
    "Standstill",
    "doorway",
    "give_way_spot",
    "guest_in_tow",
    "held_up_on_costmap",
    "local_grid_around",
    "passage_axis",
    "passage_width",
    "people_held_up",
    "recent_trail",
    "travel_heading",
    "without_the_guest",
]

GIVE_WAY_OFFSET = PEOPLE_LANE_HALF_WIDTH + max(ROBOT_FOOTPRINT) / 2.0 + 0.3
"""Metres a give-way spot keeps from a lane: the lane's half-width, half the robot and a margin.
A guest in tow adds the following gap: they stop that far short of the robot."""
DOOR_LANE_OFFSET = PEOPLE_LANE_HALF_WIDTH + 0.15
"""Metres the spot (and a following guest's stop) keeps to the side of a doorway's axis: a
walker's lane is measured to the robot's and the guest's origins, and a walker bound through
the door need not walk its very middle, hence the margin."""
DOORWAY_WIDTH = 1.4
"""Metres: an opening between facing jambs no wider than this is a doorway; the office's
corridors are wider."""
THROUGH = 0.6
"""Metres either side of a doorway, along its axis, where there must be room to stand."""
THROUGH_ROOM = 0.3
"""Metres of free space there: a corner has a wall where a doorway has the room beyond."""
GUEST_STOP_ROOM = 1.0
"""Metres of free space around where a following guest stops short of the give-way spot: room
for the robot, 0.35 m from walls and 0.6 m from the guest, to pass them on its way back out."""
SPOT_ROOM = ROBOT_CLEARANCE + 0.15
"""Metres of free space a give-way spot keeps around it: where the robot waits, others pass."""
AHEAD_DISTANCE = 1.2
"""Metres ahead of the robot of the centre of the disc treated as blocked: the way it could
not go on."""
AHEAD_RADIUS = 1.0
"""Radius of that disc, in metres: wider than a corridor, so no route squeezes past it."""
HEADING_BASE = 1.0
"""Metres back along the trail from which the direction of travel is measured."""
MAX_ROUTE = 25.0
"""Metres of route beyond which no give-way spot is looked for."""
AXIS_REACH = 8.0
"""Metres along each way that the passage's free span is measured."""
AXIS_DIRECTIONS = 36
"""Directions over half a turn among which the passage's axis is chosen (5 degrees apart)."""
TRAIL_LENGTH = 30.0
"""Metres of the robot's most recent trail that count as the people's lane."""
TRAIL_STEP = 0.25
"""Metres between the trail points kept (the readings come ten a second, closer together)."""
CHUNK = 1024
"""Spots measured against the lanes at once, nearest first."""
DOOR_CHECKS = 400
"""Spots, nearest first, whose routes are walked for a doorway before giving up."""
PEOPLE_CLEAR = PEOPLE_LANE_LENGTH + 0.1
"""Metres a give-way spot (and a following guest's stop) keeps from everyone standing near. A
walker stops for anyone in its lane, which reaches 1.5 m ahead: from this far off nobody holds
it up, whichever way it is bound."""
PERSON_BODY = 0.35
"""Metres around a person that no route to a give-way spot crosses."""
PEOPLE_REACH = 8.0
"""Metres (in x and in y) around the robot within which people on the costmap count."""
ON_TRAIL = 0.6
"""Metres from the robot's trail within which a person stands on it (the guest walks it)."""
HOLD_UP_REACH = PEOPLE_LANE_LENGTH
"""Metres from the robot within which someone standing may be held up by it: a walker's lane
reaches this far ahead of it (the robot's origin, on the floor, is in it from about 1.12 m, and
a costmap's mark lags), and the costmap does not say which way a person faces."""
STANDING_STILL = 0.15
"""Metres within which a robot still stands where it stopped (:class:`Standstill`)."""
SETTING_OFF_TURN = 0.2
"""Radians a robot yet to leave where it started turns by as it sets off (:class:`Standstill`)."""
GUEST_STOP_ROOM_WITHOUT_LANES = 0.5
"""Metres of free space around a following guest's stop when the lanes had to be given up."""


def recent_trail(points: Sequence[tuple[float, float]], *,
                 length: float = TRAIL_LENGTH, step: float = TRAIL_STEP) -> np.ndarray:
    """The last ``length`` metres of a trail given oldest first, newest first, thinned to
    points ``step`` apart; shape (n, 2), empty for an empty trail."""
    kept: list[tuple[float, float]] = []
    travelled = 0.0
    for x, y in reversed(points):
        if kept:
            gap = math.hypot(x - kept[-1][0], y - kept[-1][1])
            if gap < step:
                continue
            travelled += gap
            if travelled > length:
                break
        kept.append((float(x), float(y)))
    return np.asarray(kept, dtype=float).reshape(-1, 2)


def passage_axis(grid: OccupancyGrid2D, x: float, y: float, *, reach: float = AXIS_REACH) -> float:
    """Direction (radians, in [0, pi)) of the longest free straight span through (x, y): the
    axis of the corridor it stands in."""
    spans = _free_spans(grid, x, y, reach)
    return float(np.pi * int(np.argmax(spans)) / AXIS_DIRECTIONS)


def passage_width(grid: OccupancyGrid2D, x: float, y: float, *,
                  reach: float = AXIS_REACH) -> float:
    """Metres of the shortest free straight span through (x, y), among
    :data:`AXIS_DIRECTIONS` directions: the width of the passage it stands in (a corridor's,
    a doorway's; in the open, up to twice ``reach``). 0 in a blocked cell."""
    if grid.clearance(x, y) <= 0.0:
        return 0.0
    return float(np.min(_free_spans(grid, x, y, reach))) * grid.resolution


class Doorway(NamedTuple):
    """An opening between two jambs that face each other."""

    x: float
    """Centre: midway between the jambs."""
    y: float
    axis: float
    """Direction through the opening, square to the line between the jambs, in [0, pi)."""
    width: float
    """Metres between the jambs."""


def doorway(grid: OccupancyGrid2D, x: float, y: float, *,
            max_width: float = DOORWAY_WIDTH) -> Doorway | None:
    """The doorway (x, y) stands in, if any: the nearest blocked cell and the nearest one on the
    other side of (x, y) are its jambs, when they are at most ``max_width`` apart."""
    reach = max_width + grid.resolution
    around = grid.window(x - reach, y - reach, x + reach, y + reach)
    rows, cols = np.nonzero(grid.clearances[around.rows, around.cols] <= 0.0)
    dx, dy = around.xs[cols] - x, around.ys[rows] - y
    if dx.size == 0:
        return None
    distance = np.hypot(dx, dy)
    first = int(np.argmin(distance))
    across = dx * dx[first] + dy * dy[first] < 0.0
    if not across.any():
        return None
    second = int(np.flatnonzero(across)[np.argmin(distance[across])])
    width = float(math.hypot(dx[second] - dx[first], dy[second] - dy[first]))
    if width > max_width:
        return None
    wall = math.atan2(dy[second] - dy[first], dx[second] - dx[first])
    opening = Doorway(x + float(dx[first] + dx[second]) / 2,
                      y + float(dy[first] + dy[second]) / 2, (wall + math.pi / 2) % math.pi, width)
    return opening if _passes_through(grid, opening) else None


def _passes_through(grid: OccupancyGrid2D, opening: Doorway) -> bool:
    """Whether there is room on both sides of the opening along its axis: a doorway leads from
    one space into another, while two walls meeting at a corner also face each other across a
    narrow gap, with a wall behind it."""
    ux, uy = math.cos(opening.axis), math.sin(opening.axis)
    xs = np.array([opening.x + THROUGH * ux, opening.x - THROUGH * ux])
    ys = np.array([opening.y + THROUGH * uy, opening.y - THROUGH * uy])
    return bool(np.all(grid.clearances_at(xs, ys) >= THROUGH_ROOM))


def _free_spans(grid: OccupancyGrid2D, x: float, y: float, reach: float) -> np.ndarray:
    """Free length through (x, y), both ways, in :data:`AXIS_DIRECTIONS` directions over half a
    turn (direction k at k * pi / AXIS_DIRECTIONS), up to ``reach`` each way."""
    angles = np.linspace(0.0, 2.0 * math.pi, 2 * AXIS_DIRECTIONS, endpoint=False)
    steps = np.arange(grid.resolution, reach + 1e-9, grid.resolution)
    xs = x + np.cos(angles)[:, None] * steps[None, :]
    ys = y + np.sin(angles)[:, None] * steps[None, :]
    blocked = grid.clearances_at(xs, ys) <= 0.0
    free = np.where(blocked.any(axis=1), np.argmax(blocked, axis=1), len(steps))
    return free[:AXIS_DIRECTIONS] + free[AXIS_DIRECTIONS:]


def give_way_spot(grid: OccupancyGrid2D, *, robot: Pose2D, trail: np.ndarray,
                  guest_follows: bool = False, max_route: float = MAX_ROUTE,
                  people: np.ndarray | None = None) -> Pose2D | None:
    """The nearest spot by route, away from the way ahead and off the lanes (see the module
    docstring); None if there is none within ``max_route``. The spot faces back towards the
    robot's position.

    ``people`` (n, 2) are where others stand, as the costmap shows them: no route to the spot
    passes through them, and the spot (and a following guest's stop) keeps
    :data:`PEOPLE_CLEAR` from each, so a walker held up by the robot or its guest walks on
    whichever way it is bound. Where no spot keeps off the lanes as well (a room whose door a
    walker stands in), the lanes are given up, not the people.
    """
    people = np.zeros((0, 2)) if people is None else np.asarray(people, dtype=float).reshape(-1, 2)
    for use_lanes in (True, False):
        spot = _give_way_spot(grid, robot=robot, trail=trail, guest_follows=guest_follows,
                              max_route=max_route, people=people, use_lanes=use_lanes)
        if spot is not None or not people.size:
            return spot
    return None


def _give_way_spot(grid: OccupancyGrid2D, *, robot: Pose2D, trail: np.ndarray,
                   guest_follows: bool, max_route: float, people: np.ndarray,
                   use_lanes: bool) -> Pose2D | None:
    local = local_grid_around(grid, robot, max_route, people=people,
                               heading=None if people.size else travel_heading(trail, robot))
    routes = local.routes_from(robot.x, robot.y, ROBOT_CLEARANCE)
    if routes is None:
        return None
    rows, cols = routes.node_cells[:, 0], routes.node_cells[:, 1]
    xs, ys = routes.points(np.arange(len(routes.node_cells))).T
    near = (routes.distances <= max_route) & (local.clearances[rows, cols] >= SPOT_ROOM)
    candidates = np.flatnonzero(near)
    candidates = candidates[np.argsort(routes.distances[candidates], kind="stable")]
    lanes = _lanes(grid, robot, trail, max_route) if use_lanes else []
    offset = GIVE_WAY_OFFSET + (FOLLOW_GAP if guest_follows else 0.0)
    checked = 0
    doorways: dict[int, Doorway | None] = {}
    for start in range(0, candidates.size, CHUNK):  # nearest first: most calls stop early
        chunk = candidates[start:start + CHUNK]
        good = _acceptable(chunk, xs, ys, routes=routes, local=local, lanes=lanes,
                           offset=offset, people=people, guest_follows=guest_follows)
        for node in good[:max(DOOR_CHECKS - checked, 0)]:
            checked += 1
            if not use_lanes or _clear_of_doorway(grid, routes, int(node),
                                                  guest_follows=guest_follows,
                                                  doorways=doorways):
                x, y = float(xs[node]), float(ys[node])
                return Pose2D(x, y, math.atan2(robot.y - y, robot.x - x))
    return None


def _acceptable(chunk: np.ndarray, xs: np.ndarray, ys: np.ndarray, *, routes: RouteTree,
                local: OccupancyGrid2D, lanes: list[np.ndarray], offset: float,
                people: np.ndarray, guest_follows: bool) -> np.ndarray:
    """The route nodes of ``chunk`` (in order) that keep ``offset`` off every lane and clear
    of the people, with a following guest's stop clear of them too and with room around it
    (less room once the lanes are given up: the spot is then in a cramped place anyway)."""
    good = chunk
    if lanes:
        away = np.min([_distance_to_polyline(xs[good], ys[good], lane) for lane in lanes], axis=0)
        good = good[away >= offset]
    if people.size and good.size:
        good = good[_clear_of_people(xs[good], ys[good], people)]
    if guest_follows and good.size:
        stops = _guest_stops(routes, good)
        room = local.clearances_at(*stops.T) >= (GUEST_STOP_ROOM if lanes
                                                 else GUEST_STOP_ROOM_WITHOUT_LANES)
        if people.size:
            room &= _clear_of_people(stops[:, 0], stops[:, 1], people)
        good = good[room]
    return good


def _lanes(grid: OccupancyGrid2D, robot: Pose2D, trail: np.ndarray,
           reach: float) -> list[np.ndarray]:
    """The robot's trail (with the robot) and the axis of the passage it stands in."""
    here = np.array([[robot.x, robot.y]])
    angle = passage_axis(grid, robot.x, robot.y)
    along = reach * np.array([math.cos(angle), math.sin(angle)])
    axis = np.vstack([here - along, here + along])
    return [np.vstack([here, trail]) if trail.size else here, axis]


def _guest_stops(routes: RouteTree, nodes: np.ndarray) -> np.ndarray:
    """For each route node, where a guest trailing the robot's route to it stops: the first
    point back along the route :data:`FOLLOW_GAP` from the node in a straight line (the guest
    stops that far from the robot, however the route bends; the start, for a shorter route);
    shape (n, 2)."""
    ends = routes.points(nodes)
    current = np.array(nodes, copy=True)
    while True:
        previous = routes.predecessors[current]
        here = routes.points(current)
        step = (previous >= 0) & (np.hypot(*(here - ends).T) < FOLLOW_GAP)
        if not step.any():
            break
        current = np.where(step, previous, current)
    return routes.points(current)


def _clear_of_doorway(grid: OccupancyGrid2D, routes: RouteTree, node: int, *,
                      guest_follows: bool, doorways: dict[int, Doorway | None]) -> bool:
    """Whether the spot at ``node`` (and the guest's stop short of it) keeps to the side of the
    axis of the narrowest doorway its route passes; True when the route passes none. ``grid``
    is the map itself, without the way ahead blocked (that is no doorway); ``doorways`` caches
    what each route node stands in."""
    nodes = routes.route_to(node)
    points = routes.points(nodes)
    near_walls = np.flatnonzero(grid.clearances_at(points[:, 0], points[:, 1]) < DOORWAY_WIDTH / 2)
    found: list[Doorway] = []
    for index in near_walls:
        key = int(nodes[index])
        if key not in doorways:
            doorways[key] = doorway(grid, float(points[index, 0]), float(points[index, 1]))
        if (opening := doorways[key]) is not None:
            found.append(opening)
    if not found:
        return True
    door = min(found, key=lambda opening: opening.width)
    ux, uy = math.cos(door.axis), math.sin(door.axis)
    waiting = [points[-1]] + ([_guest_stops(routes, np.array([node]))[0]] if guest_follows else [])
    return all(abs(ux * (py - door.y) - uy * (px - door.x)) >= DOOR_LANE_OFFSET
               for px, py in waiting)


def travel_heading(trail: np.ndarray, robot: Pose2D) -> float:
    """The direction the robot was going: from the newest point of ``trail`` (newest first)
    at least :data:`HEADING_BASE` back, to the robot; its yaw if the trail is shorter. The yaw
    alone misleads: navigation's recoveries turn a blocked robot on the spot."""
    if trail.size:
        gaps = np.hypot(trail[:, 0] - robot.x, trail[:, 1] - robot.y)
        far = np.flatnonzero(gaps >= HEADING_BASE)
        if far.size:
            x, y = trail[far[0]]
            return math.atan2(robot.y - y, robot.x - x)
    return robot.yaw


def _clear_of_people(xs: np.ndarray, ys: np.ndarray, people: np.ndarray) -> np.ndarray:
    """Which points lie at least :data:`PEOPLE_CLEAR` from every person."""
    gaps = np.hypot(xs[:, None] - people[None, :, 0], ys[:, None] - people[None, :, 1])
    clear: NDArray[np.bool_] = np.all(gaps >= PEOPLE_CLEAR, axis=1)
    return clear


def people_held_up(people: np.ndarray, *, robot: Pose2D,
                   reach: float = HOLD_UP_REACH) -> np.ndarray:
    """Those of ``people`` (n, 2) within ``reach`` of the robot, nearest first: whoever faces it
    from there has it in their lane, and a walker waits as long as it stands there."""
    people = np.asarray(people, dtype=float).reshape(-1, 2)
    gaps = np.hypot(people[:, 0] - robot.x, people[:, 1] - robot.y)
    near: NDArray[np.float64] = people[gaps <= reach][np.argsort(gaps[gaps <= reach],
                                                                 kind="stable")]
    return near


def held_up_on_costmap(costmap: Costmap2D, occupancy: OccupancyGrid2D, *, robot: Pose2D,
                       trail: np.ndarray | None = None,
                       reach: float = HOLD_UP_REACH) -> np.ndarray:
    """Whom the robot may hold up (:func:`people_held_up`) among the people navigation's
    costmap shows; given the robot's ``trail``, the guest in tow is left out
    (:func:`without_the_guest`): they stop behind the robot of their own accord."""
    people = people_on_costmap(costmap, occupancy, x=robot.x, y=robot.y, reach=PEOPLE_REACH)
    if trail is not None:
        people = without_the_guest(people, robot=robot, trail=trail)
    return people_held_up(people, robot=robot, reach=reach)


class Standstill:
    """How long the robot has stood: the sim seconds since it was last more than ``still``
    metres from where it stopped. Turning in place on its way is standing: nobody in a lane
    gets by. Before the robot has left where it started, a turn of more than ``turn`` is
    setting off, not standing (the robot that has just dropped off its guest turns and leaves
    beside them), and the count starts again; a robot that neither moves nor turns from the
    start stands from the start (someone stands where it must go, and navigation waits).

    Args:
        still: metres of drift that still count as standing (a stopped robot's estimate jitters)
        turn: radians of turning at the start that count as setting off
    """

    def __init__(self, *, still: float = STANDING_STILL, turn: float = SETTING_OFF_TURN) -> None:
        self.still = still
        self.turn = turn
        self._since: tuple[float, float, float, float] | None = None
        self._on_its_way = False

    def forget(self) -> None:
        """Start over: the next position is where the robot starts from."""
        self._since = None
        self._on_its_way = False

    def stood(self, x: float, y: float, yaw: float, now: float) -> float:
        """Sim seconds the robot at (x, y), facing ``yaw``, has stood by ``now``."""
        since = self._since
        if since is None:
            self._since = (x, y, yaw, now)
        elif math.hypot(x - since[0], y - since[1]) > self.still:
            self._since = (x, y, yaw, now)
            self._on_its_way = True
        elif not self._on_its_way and abs(_wrapped(yaw - since[2])) > self.turn:
            self._since = (x, y, yaw, now)
        assert self._since is not None
        return max(0.0, now - self._since[3])


def _wrapped(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def without_the_guest(people: np.ndarray, *, robot: Pose2D, trail: np.ndarray) -> np.ndarray:
    """``people`` less the guest in tow: of those standing on the robot's trail (within
    :data:`ON_TRAIL` of it), the one the robot passed last. The guest walks the trail behind the
    robot, so nobody stands on it between them, while a walker ahead of the robot is not on it
    at all and one that stands on it further back was passed before the guest. The guest moves
    with the robot, so no spot need keep clear of where they stand now. Nobody on the trail:
    ``people`` as they are."""
    people = np.asarray(people, dtype=float).reshape(-1, 2)
    guest = guest_in_tow(people, robot=robot, trail=trail)
    return people if guest is None else np.delete(people, guest, axis=0)


def guest_in_tow(people: np.ndarray, *, robot: Pose2D, trail: np.ndarray) -> int | None:
    """Which of ``people`` is the guest in tow (:func:`without_the_guest` says how it is
    told), by index; None if nobody stands on the trail."""
    people = np.asarray(people, dtype=float).reshape(-1, 2)
    if not people.size or not trail.size:
        return None
    gaps = np.hypot(people[:, None, 0] - trail[None, :, 0], people[:, None, 1] - trail[None, :, 1])
    on_trail = gaps <= ON_TRAIL
    passed = np.where(on_trail.any(axis=1), np.argmax(on_trail, axis=1), trail.shape[0])
    guest = int(np.argmin(passed))
    return None if passed[guest] == trail.shape[0] else guest


def local_grid_around(grid: OccupancyGrid2D, robot: Pose2D, reach: float, *,
                       people: np.ndarray, heading: float | None,
                       person_body: float = PERSON_BODY) -> OccupancyGrid2D:
    """The part of the grid within ``reach`` of the robot (no route of that length leaves it),
    with every person's body (``person_body`` round them) marked occupied and, given a
    ``heading``, a disc of :data:`AHEAD_RADIUS` ahead of the robot: the way it could not go on,
    when it cannot see who stands there."""
    around = grid.window(robot.x - reach, robot.y - reach, robot.x + reach, robot.y + reach)
    values = np.array(grid.values[around.rows, around.cols], dtype=np.int16, copy=True)
    origin_x = grid.origin_x + around.cols.start * grid.resolution
    origin_y = grid.origin_y + around.rows.start * grid.resolution
    discs = [(px, py, person_body) for px, py in people]
    if heading is not None:
        discs.append((robot.x + AHEAD_DISTANCE * math.cos(heading),
                      robot.y + AHEAD_DISTANCE * math.sin(heading), AHEAD_RADIUS))
    for cx, cy, radius in discs:
        values[np.hypot(around.xs[None, :] - cx, around.ys[:, None] - cy) <= radius] = 100
    return OccupancyGrid2D(values=values, resolution=grid.resolution,
                           origin_x=origin_x, origin_y=origin_y)


def _distance_to_polyline(xs: np.ndarray, ys: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline ``line`` (n, 2); a single point counts as one."""
    points = np.stack([xs, ys], axis=1)[:, None, :]
    if len(line) == 1:
        to_point: NDArray[np.float64] = np.hypot(*(points[:, 0, :] - line[0]).T)
        return to_point
    starts, ends = line[:-1][None, :, :], line[1:][None, :, :]
    along = ends - starts
    squared = np.maximum(np.sum(along * along, axis=2), 1e-12)
    t = np.clip(np.sum((points - starts) * along, axis=2) / squared, 0.0, 1.0)
    nearest = starts + t[:, :, None] * along
    to_line: NDArray[np.float64] = np.min(np.hypot(*(points - nearest).transpose(2, 0, 1)),
                                          axis=1)
    return to_line
