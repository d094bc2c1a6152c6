"""Where the robot should go next: goal and waypoint computation from the map and the boxes.

The seed aimed at "area centre − 1 m in x", which can leave the area (checkpoint 1 or 4 never
fires) and ignores where the guest will stand. The functions here compute goals from what the
executive knows — the :class:`~bt_servicesim.planning.occupancy.OccupancyGrid2D` from
``/servicebot/map``, the referee's RoomInfo boxes, the start pose and odometry — and never from the
simulator. Every goal lies on a free cell with room for the robot (:data:`ROBOT_CLEARANCE`) that is
connected to the robot's position, and every figure that shapes them is a named constant below
or derived from the competition's rules (:mod:`bt_servicesim.planning.rules`).

Each behaviour reads its input ports, computes in ``update`` — pure and non-blocking; on the
1200x1200 office map the heaviest, :class:`DropOffGoal` and :class:`ExplorationWaypoints`,
take about 40 ms (at most about 0.1 s, for the largest target areas), the others a few
milliseconds — and writes its output port: SUCCESS with the result, or FAILURE with a feedback
message naming the missing input or why no goal exists.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterable, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from bt_servicesim.planning.geometry import Box, Point, Pose2D
from bt_servicesim.planning.occupancy import OccupancyGrid2D, RouteTree
from bt_servicesim.planning.rules import (
    FOLLOW_GAP,
    GOAL_TOLERANCE,
    GUEST_SPAWN_PADDING,
    PEOPLE_LANE_LENGTH,
    PERSON_APPROXIMATION_RADIUS,
    PERSON_BODY_RADIUS,
    PICKUP_REACH,
    ROBOT_FOOTPRINT,
)
from bt_servicesim.planning.way_out import way_back_open, way_back_point

__all__ = [
    "TrailingPlan",
    "drop_off_goal",
    "drop_off_reposition_goal",
    "jitter_goal",
    "pickup_goal",
    "return_goal",
]


ROBOT_CLEARANCE = 0.35
"""Metres of free space a goal needs around it (footprint 0.4 x 0.5 m: half-diagonal 0.32)."""
SIGHT_CLEARANCE = ROBOT_CLEARANCE - 0.1
"""Clearance along a straight leg the robot drives (a lattice step less than a goal's)."""
TRAIL_ALONG_ERROR = 0.45
"""Where the guest stops, along the trail: the goal tolerance plus the guest's own spread."""
TRAIL_ACROSS_ERROR = 0.25
"""Where the guest stops, across the trail."""
SOCIAL_DISTANCE = 1.1
"""Metres a pick-up goal keeps from where the guest may stand: the referee books approximation
within :data:`~bt_servicesim.planning.rules.PERSON_APPROXIMATION_RADIUS` of the robot's base."""
PERSON_CLEARANCE = 0.2
"""A person's origin keeps at least this far from walls: a search covers where one can stand."""
JITTER = 0.3
"""Largest jitter offset on either axis."""
STAY_MARGIN = 0.1
"""A robot whose trailing guest has this :func:`trailing_margin` may stay where it is."""
GUEST_BERTH = 0.6
"""A robot's last leg keeps this far from where the guest stands (people are obstacles)."""
PEOPLE_KEEP = PERSON_APPROXIMATION_RADIUS + PERSON_BODY_RADIUS
"""Metres a drop-off goal, and the guest's spot behind it, keep from anyone else standing
near: the referee's ghost cylinder and a body. The guest stays there for good, the robot until
the referee answers."""
SIGHT_LOOKBACK = 20.0
"""How far back along the route the robot's last turn before a spot is looked for."""
SIGHT_STRIDE = 3
"""Every how many route nodes (0.1 m apart) the last turn is looked for."""
DOORWAY_KEEP = PEOPLE_LANE_LENGTH + 0.35 + max(ROBOT_FOOTPRINT)
"""Metres a dropped-off guest keeps from the doorways near the box, where the box allows.
The guest then stands for good, and a walker who meets them in its lane waits as long as they
stand: one bound through the door stops :data:`~bt_servicesim.planning.rules.PEOPLE_LANE_LENGTH`
short of them, and from this far off it stands a body (0.35 m) and the robot's length inside
the door, not in it, so the robot can still leave the room."""


# ============================================================================ plain geometry
def box_depth(box: Box, x: Any, y: Any) -> Any:
    """Signed distance from (x, y) to the box's boundary: positive inside (arrays welcome)."""
    return np.minimum(np.minimum(x - box.min_x, box.max_x - x),
                      np.minimum(y - box.min_y, box.max_y - y))


def shrunk(box: Box, margin_x: float, margin_y: float) -> Box:
    """The box shrunk on each side, by at most half its size (so it may become a line)."""
    mx = min(margin_x, (box.max_x - box.min_x) / 2.0)
    my = min(margin_y, (box.max_y - box.min_y) / 2.0)
    return Box(box.min_x + mx, box.min_y + my, box.max_x - mx, box.max_y - my)


def guest_spawn_area(box: Box) -> Box:
    """Where the guest may spawn: the box less :data:`GUEST_SPAWN_PADDING` (centre line if thin)."""
    return shrunk(box, GUEST_SPAWN_PADDING, GUEST_SPAWN_PADDING)


def farthest_corner(area: Box, xs: Any, ys: Any) -> Any:
    """Distance from (xs, ys) to the farthest point of ``area``."""
    return np.hypot(np.maximum(abs(xs - area.min_x), abs(xs - area.max_x)),
                    np.maximum(abs(ys - area.min_y), abs(ys - area.max_y)))


def distance_to_box(box: Box, x: Any, y: Any) -> Any:
    """Distance from (x, y) to the box (0 inside)."""
    dx = np.maximum(np.maximum(box.min_x - x, x - box.max_x), 0.0)
    dy = np.maximum(np.maximum(box.min_y - y, y - box.max_y), 0.0)
    return np.hypot(dx, dy)


def trailing_margin(box: Box, x: float, y: float, heading: Point) -> float:
    """How deep the guest stays in the box if it stops near (x, y) trailing along ``heading``.

    The smallest box depth over the points :data:`TRAIL_ALONG_ERROR` ahead of and behind (x, y)
    along the heading and :data:`TRAIL_ACROSS_ERROR` to either side.
    """
    (ux, uy), (nx, ny) = heading, (-heading[1], heading[0])
    probes = [(ux * TRAIL_ALONG_ERROR, uy * TRAIL_ALONG_ERROR),
              (nx * TRAIL_ACROSS_ERROR, ny * TRAIL_ACROSS_ERROR)]
    return float(min(box_depth(box, x + sign * dx, y + sign * dy)
                     for dx, dy in probes for sign in (1.0, -1.0)))


def _unit(dx: float, dy: float) -> Point | None:
    length = math.hypot(dx, dy)
    return None if length < 1e-9 else (dx / length, dy / length)


def _heading(pose: Pose2D) -> Point:
    return (math.cos(pose.yaw), math.sin(pose.yaw))


def _best_cell(
    grid: OccupancyGrid2D, area: Box, allowed: np.ndarray,
    cost: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> Point | None:
    """The centre of the allowed cell within ``area`` of least cost; None if there is none."""
    window = grid.window(area.min_x, area.min_y, area.max_x, area.max_y)
    if window.is_empty:
        return None
    xs, ys = np.meshgrid(window.xs, window.ys)
    costs = np.where(allowed[window.rows, window.cols], cost(xs, ys), np.inf)
    best = np.unravel_index(int(np.argmin(costs)), costs.shape)
    return (float(xs[best]), float(ys[best])) if np.isfinite(costs[best]) else None


# ============================================================================ pick-up
def pickup_goal(box: Box, grid: OccupancyGrid2D, robot: Pose2D, *,
                people: np.ndarray | None = None) -> Pose2D | None:
    """A reachable goal INSIDE ``box``, within pick-up reach of wherever the guest may stand,
    but not on top of them.

    Checkpoint 1 wants the robot's origin in the box, and navigation stops within
    :data:`GOAL_TOLERANCE` of the goal, so the goal keeps that far from the box's edges when it
    can (then half, then none). The guest spawns somewhere in the box less its padding, and the
    referee hands them over within 2.0 m: every cell whose farthest spawn point lies within
    :data:`PICKUP_REACH` qualifies. Among those the goal keeps :data:`SOCIAL_DISTANCE` from the
    spawn area where it can — the seed drove at the centre, onto the guest, and a robot within
    0.75 m of a person is penalised every physics step — and is the nearest to the robot. The
    robot faces the box centre.

    ``people`` (n, 2) are those the robot sees standing near the box (navigation's costmap): the
    goal keeps :data:`PEOPLE_KEEP` from them where the box leaves room, before it keeps its
    distance from the spawn area. A walker can stand in a pick-up box for good, waiting for a
    robot in its lane, and a goal on top of them is never reached.
    """
    reachable = grid.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)
    spawn = guest_spawn_area(box)
    seen = np.zeros((0, 2)) if people is None else np.asarray(people, dtype=float).reshape(-1, 2)

    def cost(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        beyond_reach = np.maximum(farthest_corner(spawn, xs, ys) - PICKUP_REACH, 0.0)
        beside_people = np.zeros_like(xs)
        for px, py in seen:
            beside_people += np.maximum(PEOPLE_KEEP - np.hypot(xs - px, ys - py), 0.0)
        crowding = np.maximum(SOCIAL_DISTANCE - distance_to_box(spawn, xs, ys), 0.0)
        travel = np.hypot(xs - robot.x, ys - robot.y)
        costs: NDArray[np.float64] = (100.0 * beyond_reach + 50.0 * beside_people
                                      + 10.0 * crowding + 1e-2 * travel)
        return costs

    for margin in (GOAL_TOLERANCE, GOAL_TOLERANCE / 2.0, 0.0):
        spot = _best_cell(grid, shrunk(box, margin, margin), reachable, cost)
        if spot is not None:
            return Pose2D(spot[0], spot[1], _facing(box.centre, spot, robot))
    return None


def _facing(target: Point, spot: Point, robot: Pose2D) -> float:
    """Yaw at ``spot`` towards ``target``; on it, the heading of arrival from the robot."""
    for origin in (spot, (robot.x, robot.y)):
        direction = _unit(target[0] - origin[0], target[1] - origin[1])
        if direction is not None and math.dist(origin, target) > 0.1:
            return math.atan2(direction[1], direction[0])
    return robot.yaw


# ============================================================================ drop-off
class TrailingPlan(NamedTuple):
    """A robot goal and where the guest trailing the robot should stop when it gets there."""

    goal: Pose2D
    """The robot's goal; its yaw is the heading the robot arrives with."""
    guest_spot: Point
    """Where the guest stops: :data:`FOLLOW_GAP` behind the goal along the arrival heading."""
    margin: float
    """:func:`trailing_margin` of the guest spot: the guest's depth in the box despite errors."""
    travel: float
    """Route length from the robot to the goal."""


def drop_off_goal(box: Box, grid: OccupancyGrid2D, robot: Pose2D, *,
                  doorways: Sequence[Point] = (),
                  people: np.ndarray | None = None) -> TrailingPlan | None:
    """A robot goal that leaves the FOLLOWING GUEST inside the drop-off ``box``.

    Checkpoint 3 checks the guest's origin, not the robot's, and the guest walks along the
    robot's trail and stops about :data:`FOLLOW_GAP` (1.2 m) behind it. So the goal is chosen
    for a *guest spot* T in the box: the robot must pass straight through T and stop 1.2 m
    beyond it, G = T + 1.2·u, where u is the direction in which the robot's route arrives at T.

    The arrival direction comes from the robot's side, not from the box: over the shortest routes
    from the robot (:class:`~bt_servicesim.planning.occupancy.RouteTree`) the last turn before T is
    the farthest route point still in straight sight of T (a door jamb, a corner, or the robot
    itself in open space), and u points from it to T. G must be free with room for the robot, the
    leg T→G clear, and G must not be reachable more directly than through T (else the planner would
    not pass T).

    Every candidate T on a 0.2 m lattice in the box is scored by :func:`trailing_margin` — the
    guest's depth in the box when it stops up to 0.45 m off along the trail or 0.25 m across it —
    and the best margin wins, the shorter route among near-equals. For a 3x3 room that is the
    centre (margin about 1 m). For the small boxes the robot drives THROUGH the box and stops
    past it: in a 1.8x1.5 cubicle strip or a 2x1 corner cubicle G lies outside the box, 1.2 m
    beyond the centre, and the margin is largest when the arrival runs along the long axis
    (1.8x1.5 along x: 0.45 m; along y: 0.3 m; a 2x1 across its 1 m side only 0.05 m). A single
    goal cannot choose the arrival side — the route does — so a thin box approached across is
    left to the reposition after a refusal (:func:`drop_off_reposition_goal`).

    While guiding, the guest trails about 1.2 m behind the robot along its heading, so plans
    whose last leg passes within :data:`GUEST_BERTH` of that spot (driving back through the
    guest) are left out. The robot may already be in place — the mission asks again after a
    refused drop-off and a reposition — so staying put is a candidate too, when the guest's
    spot behind leaves them at least :data:`STAY_MARGIN` deep: it wins over any move of no
    clearly better margin. If no spot works (e.g. the box lies in a dead end), the goal falls
    back to the reachable point inside the box nearest its centre and the plan's margin says
    how far off the guest is.

    ``doorways`` are the centres of the doorways near the box
    (:func:`bt_servicesim.planning.entrances.doorways_near`): a guest spot keeps
    :data:`DOORWAY_KEEP` from each where any spot of the box does, since the guest stays there
    for good and a walker they hold up in a doorway shuts it.

    Before either, a plan must leave the robot its way back: with the guest standing at the
    guest spot, the goal stays connected to the arrival route a little before the spot
    (:func:`~bt_servicesim.planning.way_out.way_back_open`). A guest left in the middle of a
    corridor shuts it for good; a walker who then comes from ahead waits for the robot, and
    the robot stands between the two until the mission's time runs out.

    ``people`` (n, 2) are the others the robot sees standing near (navigation's costmap, the
    guest in tow left out). They stand in the way back as the guest does, and the goal and the
    guest spot keep :data:`PEOPLE_KEEP` from each where any plan can: two walkers who wait for
    each other, or an idler, can stand in a drop-off room for good, and a goal beside them
    leaves the robot booked, and boxed in, for the rest of the mission. Then the doorways are
    given up before the people, and the people before the way back.
    """
    routes = grid.routes_from(robot.x, robot.y, ROBOT_CLEARANCE)
    if routes is None:
        return None
    people = np.zeros((0, 2)) if people is None else np.asarray(people, dtype=float).reshape(-1, 2)
    stay = _staying_plan(box, robot)
    clear_of_guest = _clear_of(stay.guest_spot)
    way_out = _way_back_stays_open(grid, routes, people)
    for need_way_out, mind_people, off_doors in _relaxations(doorways, people):
        def allowed(candidate: TrailingPlan, open_way: bool = need_way_out,
                    mind: bool = mind_people, doors: bool = off_doors) -> bool:
            return ((not doors or _off_doorways(candidate, doorways))
                    and (not mind or _clear_of_people(candidate, people))
                    and (not open_way or way_out(candidate)))

        def keep(candidate: TrailingPlan,
                 allowed: Callable[[TrailingPlan], bool] = allowed) -> bool:
            return clear_of_guest(candidate) and allowed(candidate)

        plans = list(_trailing_plans(box, grid, routes, robot, keep=keep))
        if stay.margin >= STAY_MARGIN and allowed(stay):
            plans.append(stay)
        plan = _best_plan(plans)
        if plan is not None:
            return plan
    return _inside_fallback(box, grid, robot, routes)


def _relaxations(doorways: Sequence[Point],
                 people: np.ndarray) -> list[tuple[bool, bool, bool]]:
    """What a drop-off plan must do, strictest first: (leave the way back open, keep clear of
    the people, keep off the doorways). The doorways are given up first, then the people, then
    the way back; a rule with nothing to apply it to (no doorways, nobody near) is never tried
    off."""
    return [(way_out, mind_people, off_doors)
            for way_out in (True, False)
            for mind_people in ((True, False) if len(people) else (False,))
            for off_doors in ((True, False) if doorways else (False,))]


def _way_back_stays_open(grid: OccupancyGrid2D, routes: RouteTree,
                         people: np.ndarray) -> Callable[[TrailingPlan], bool]:
    """Whether the robot at a plan's goal can get back past the guest standing at its guest
    spot (give or take TRAIL_ACROSS_ERROR) and the ``people`` standing where they are, to the
    arrival route :data:`~bt_servicesim.planning.way_out.WAY_BACK` before it
    (:func:`~bt_servicesim.planning.way_out.way_back_open`)."""

    def stays_open(plan: TrailingPlan) -> bool:
        back = way_back_point(routes, plan.guest_spot)
        return back is not None and way_back_open(
            grid, goal=(plan.goal.x, plan.goal.y), guest_spot=plan.guest_spot, back=back,
            guest_spread=TRAIL_ACROSS_ERROR, people=people if len(people) else None)

    return stays_open


def _clear_of_people(plan: TrailingPlan, people: np.ndarray) -> bool:
    """Whether the plan's goal and guest spot keep PEOPLE_KEEP from everyone in ``people``."""
    for x, y in ((plan.goal.x, plan.goal.y), plan.guest_spot):
        if np.any(np.hypot(people[:, 0] - x, people[:, 1] - y) < PEOPLE_KEEP):
            return False
    return True


def _off_doorways(plan: TrailingPlan, doorways: Sequence[Point]) -> bool:
    """Whether the plan's guest spot keeps DOORWAY_KEEP from every doorway."""
    return all(math.dist(plan.guest_spot, door) >= DOORWAY_KEEP for door in doorways)


def _staying_plan(box: Box, robot: Pose2D) -> TrailingPlan:
    """Stay put: the guest is taken to trail FOLLOW_GAP behind along the robot's heading."""
    heading = _heading(robot)
    spot = (robot.x - FOLLOW_GAP * heading[0], robot.y - FOLLOW_GAP * heading[1])
    return TrailingPlan(robot, spot, trailing_margin(box, *spot, heading), 0.0)


def _guest_spots(box: Box, spacing: float = 0.2) -> list[Point]:
    """Candidate guest spots on a lattice centred in the box, deepest first."""
    half_x, half_y = (box.max_x - box.min_x) / 2.0, (box.max_y - box.min_y) / 2.0
    cx, cy = box.centre
    steps_x, steps_y = int(half_x / spacing), int(half_y / spacing)
    spots = [(cx + i * spacing, cy + j * spacing)
             for i in range(-steps_x, steps_x + 1) for j in range(-steps_y, steps_y + 1)]
    spots = [spot for spot in spots if box_depth(box, *spot) > 0.05]
    return sorted(spots, key=lambda spot: -box_depth(box, *spot))


def _trailing_plans(
    box: Box, grid: OccupancyGrid2D, routes: RouteTree, robot: Pose2D,
    keep: Callable[[TrailingPlan], bool] = lambda plan: True,
) -> Iterable[TrailingPlan]:
    """Valid plans, spot by spot, deepest spots first; stops once no spot can do better."""
    best = -math.inf
    for spot in _guest_spots(box):
        if box_depth(box, *spot) < best - 0.05:
            return
        plan = _plan_through(box, grid, routes, robot, spot)
        if plan is not None and keep(plan):
            best = max(best, plan.margin)
            yield plan


def _plan_through(
    box: Box, grid: OccupancyGrid2D, routes: RouteTree, robot: Pose2D, spot: Point
) -> TrailingPlan | None:
    """The goal FOLLOW_GAP beyond ``spot`` along the route's arrival there, if it works."""
    to_spot = routes.distance_to(*spot)
    if not math.isfinite(to_spot):
        return None
    heading = _arrival_direction(grid, routes, robot, spot) or _heading(robot)
    gx, gy = spot[0] + FOLLOW_GAP * heading[0], spot[1] + FOLLOW_GAP * heading[1]
    travel = routes.distance_to(gx, gy)
    if not (grid.is_free(gx, gy, ROBOT_CLEARANCE) and math.isfinite(travel)):
        return None
    if travel < to_spot + 0.9 * FOLLOW_GAP:  # reached more directly than through the spot
        return None
    if not grid.clear_lines(spot[0], spot[1], [gx], [gy], SIGHT_CLEARANCE)[0]:
        return None
    goal = Pose2D(gx, gy, math.atan2(heading[1], heading[0]))
    return TrailingPlan(goal, spot, trailing_margin(box, *spot, heading), travel)


def _arrival_direction(
    grid: OccupancyGrid2D, routes: RouteTree, robot: Pose2D, spot: Point
) -> Point | None:
    """Unit direction in which the shortest route arrives at ``spot``; None if it starts there.

    In straight sight of the robot that is from the robot; otherwise from the farthest point
    of the route (walking back from the spot) still in straight sight of the spot.
    """
    sx, sy = spot
    if grid.clear_lines(sx, sy, [robot.x], [robot.y], SIGHT_CLEARANCE)[0]:
        turn = (robot.x, robot.y)
    else:
        path = routes.path_back_from(sx, sy, SIGHT_LOOKBACK)[::SIGHT_STRIDE]
        if len(path) == 0:
            return None
        visible = grid.clear_lines(sx, sy, path[:, 0], path[:, 1], SIGHT_CLEARANCE)
        hidden = np.flatnonzero(~visible)
        last = max(int(hidden[0]) - 1, 0) if hidden.size else len(path) - 1
        turn = (float(path[last, 0]), float(path[last, 1]))
    if math.dist(turn, spot) < 0.2:
        return None
    return _unit(sx - turn[0], sy - turn[1])


def _best_plan(plans: Iterable[TrailingPlan], tie: float = 0.05) -> TrailingPlan | None:
    """The plan with the largest margin; the shortest travel among those within ``tie`` of it."""
    candidates = list(plans)
    if not candidates:
        return None
    best_margin = max(plan.margin for plan in candidates)
    return min((plan for plan in candidates if plan.margin >= best_margin - tie),
               key=lambda plan: plan.travel)


def _inside_fallback(
    box: Box, grid: OccupancyGrid2D, robot: Pose2D, routes: RouteTree
) -> TrailingPlan | None:
    """The robot inside the box near its centre, the guest wherever that leaves them."""
    goal = pickup_goal(box, grid, robot)
    if goal is None:
        return None
    heading = _heading(goal)
    spot = (goal.x - FOLLOW_GAP * heading[0], goal.y - FOLLOW_GAP * heading[1])
    return TrailingPlan(goal, spot, trailing_margin(box, *spot, heading),
                        routes.distance_to(goal.x, goal.y))


def drop_off_reposition_goal(
    box: Box, grid: OccupancyGrid2D, robot: Pose2D
) -> TrailingPlan | None:
    """After a refused drop-off: a different goal that pulls the trailing guest deeper in.

    The guest is taken to stand :data:`FOLLOW_GAP` behind the robot along its heading (it
    trailed the last leg). Two kinds of move are weighed by the guest's new
    :func:`trailing_margin`:

    - *pull forward*: drive s metres straight on (0.5 to 3 m, as far as the way is clear); the
      guest follows the trail and ends s metres further along the same line — the cheap fix
      when the guest stopped short of the box;
    - *drive through*: a fresh :func:`drop_off_goal` plan from here (which keeps clear of the
      guest), at least 0.5 m away; for a thin box it typically crosses along the long axis and
      stops past the far side.

    The deepest wins (the shorter move among near-equals). None only if no move is possible.
    """
    routes = grid.routes_from(robot.x, robot.y, ROBOT_CLEARANCE)
    if routes is None:
        return None
    clear_of_guest = _clear_of(_staying_plan(box, robot).guest_spot)

    def feasible(plan: TrailingPlan) -> bool:
        far_enough = math.dist((plan.goal.x, plan.goal.y), (robot.x, robot.y)) >= 0.5
        return far_enough and clear_of_guest(plan)

    through = list(_trailing_plans(box, grid, routes, robot, keep=feasible))
    return _best_plan([*_forward_pulls(box, grid, robot), *through])


def _clear_of(guest: Point) -> Callable[[TrailingPlan], bool]:
    """Whether a plan's last leg keeps GUEST_BERTH from the guest standing at ``guest``."""

    def keeps_clear(plan: TrailingPlan) -> bool:
        goal = (plan.goal.x, plan.goal.y)
        return _distance_to_segment(guest, plan.guest_spot, goal) >= GUEST_BERTH

    return keeps_clear


def _distance_to_segment(point: Point, start: Point, end: Point) -> float:
    """Distance from ``point`` to the segment from ``start`` to ``end``."""
    dx, dy = end[0] - start[0], end[1] - start[1]
    length_squared = dx * dx + dy * dy
    t = 0.0 if length_squared == 0.0 else (
        ((point[0] - start[0]) * dx + (point[1] - start[1]) * dy) / length_squared)
    t = min(max(t, 0.0), 1.0)
    return math.dist(point, (start[0] + t * dx, start[1] + t * dy))


def _forward_pulls(box: Box, grid: OccupancyGrid2D, robot: Pose2D) -> list[TrailingPlan]:
    """Plans driving 0.5 to 3 m straight on, as far as the way is clear and the goal free."""
    ux, uy = _heading(robot)
    reaches = np.arange(0.5, 3.0 + 1e-9, 0.1)
    xs, ys = robot.x + reaches * ux, robot.y + reaches * uy
    clear = grid.clear_lines(robot.x, robot.y, xs, ys, SIGHT_CLEARANCE)
    plans = []
    for reach, x, y, ok in zip(reaches, xs, ys, clear, strict=True):
        if not (ok and grid.is_free(float(x), float(y), ROBOT_CLEARANCE)):
            break
        spot = (float(x) - FOLLOW_GAP * ux, float(y) - FOLLOW_GAP * uy)
        plans.append(TrailingPlan(Pose2D(float(x), float(y), robot.yaw), spot,
                                  trailing_margin(box, *spot, (ux, uy)), float(reach)))
    return plans


# ============================================================================ return, jitter
def return_goal(start: Pose2D, grid: OccupancyGrid2D) -> Pose2D | None:
    """The start pose itself (inside the start area), or the nearest cell with room for the
    robot within half a metre of it; None if there is none."""
    spot = grid.nearest_free(start.x, start.y, clearance=ROBOT_CLEARANCE, max_radius=0.5)
    if spot is None:
        return None
    return start if spot == (start.x, start.y) else Pose2D(spot[0], spot[1], start.yaw)


def jitter_goal(goal: Pose2D, grid: OccupancyGrid2D, rng: random.Random) -> Pose2D:
    """``goal`` moved by up to :data:`JITTER` on each axis onto free space with room for the
    robot; the goal itself if ten draws find none (a recovery must not fail for want of room)."""
    for _draw in range(10):
        x = goal.x + rng.uniform(-JITTER, JITTER)
        y = goal.y + rng.uniform(-JITTER, JITTER)
        spot = grid.nearest_free(x, y, clearance=ROBOT_CLEARANCE, max_radius=JITTER)
        if spot is not None and math.dist(spot, (goal.x, goal.y)) > 0.05:
            return Pose2D(spot[0], spot[1], goal.yaw)
    return goal















# ============================================================================ behaviours






















