"""Whether the robot can still leave a spot once the guest stands where it leaves them.

After the drop-off the guest stands for good where they stopped, about
:data:`~bt_servicesim.planning.rules.FOLLOW_GAP` behind the robot, on the way the robot came.
In a corridor or a narrow room a guest left in the middle shuts that way: the robot can go on
only forwards, and a walker who comes from ahead and waits for the robot (it stands in the
walker's lane) shuts the other side too, for the rest of the mission. So a drop-off plan is
preferred whose way back past the guest stays open.

The check is local and static: on the map within :data:`WAY_OUT_REACH` of the guest spot, the
guest's body (:data:`GUEST_BODY`) and any other people given are marked occupied, and the goal
must stay connected, with the room a passing robot needs (:data:`PASSING_CLEARANCE`), to the
point of the robot's arrival route :data:`WAY_BACK` metres before the guest spot, by a way at most
:data:`WAY_BACK_DETOUR` longer than the straight one past the spot: round the guest, not round
a block of rooms, whose far side leads through whoever comes from ahead. Navigation keeps its own
margin round people (the costmap's inscribed radius plus the person's mark), so the way counted
open here is one a planner does not call cut off.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Point
from bt_servicesim.planning.occupancy import OccupancyGrid2D, RouteTree, Window

__all__ = ["GUEST_BODY", "PASSING_CLEARANCE", "WAY_BACK", "WAY_BACK_DETOUR", "WAY_OUT_REACH",
           "way_back_open", "way_back_point"]

PASSING_CLEARANCE = 0.25
"""Metres of free space the way out needs round the robot's centre: the radius navigation's
costmap gives the robot (the shipped parameters' ``robot_radius``), less than a goal's room."""
GUEST_BODY = 0.35
"""Metres round the standing guest (and anyone else given) that the way out never crosses."""
WAY_BACK = 2.5
"""Metres back along the arrival route from the guest spot to the point the way out must reach:
beyond the guest's body and the robot's room round it."""
WAY_BACK_DETOUR = 1.5
"""Metres longer than the straight way past the guest spot the way back may be: round the
guest, not round the block (a way round the block leads through whoever comes from ahead)."""
WAY_OUT_REACH = WAY_BACK + 1.5
"""Metres (in x and in y) round the guest spot that the check looks at."""


def way_back_point(routes: RouteTree, guest_spot: Point) -> Point | None:
    """The point of the route from the robot to ``guest_spot`` about :data:`WAY_BACK` metres
    before it (the route's start if that is nearer); None if the spot is unreachable."""
    path = routes.path_back_from(guest_spot[0], guest_spot[1], WAY_BACK)
    if len(path) == 0:
        return None
    return float(path[-1, 0]), float(path[-1, 1])


def way_back_open(grid: OccupancyGrid2D, *, goal: Point, guest_spot: Point, back: Point,
                  guest_spread: float = 0.0, people: np.ndarray | None = None) -> bool:
    """Whether the robot at ``goal`` can reach ``back`` with the guest standing at
    ``guest_spot``, give or take ``guest_spread`` metres (where a trailing guest stops varies),
    and ``people`` (n, 2) standing where they are, on the map round the spot. A ``back`` point
    within the guest's body or its room counts as shut."""
    gx, gy = guest_spot
    around = grid.window(gx - WAY_OUT_REACH, gy - WAY_OUT_REACH,
                         gx + WAY_OUT_REACH, gy + WAY_OUT_REACH)
    if around.is_empty:
        return False
    values = np.array(grid.values[around.rows, around.cols], dtype=np.int16, copy=True)
    standing = [guest_spot] + ([] if people is None else [tuple(p) for p in np.asarray(
        people, dtype=float).reshape(-1, 2)])
    bodies = [GUEST_BODY + guest_spread] + [GUEST_BODY] * (len(standing) - 1)
    for (px, py), body in zip(standing, bodies, strict=True):
        _mark_body(values, around, centre=(px, py), radius=body, margin=grid.resolution)
    local = OccupancyGrid2D(values=values, resolution=grid.resolution,
                            origin_x=grid.origin_x + around.cols.start * grid.resolution,
                            origin_y=grid.origin_y + around.rows.start * grid.resolution)
    routes = local.routes_from(goal[0], goal[1], PASSING_CLEARANCE)
    if routes is None or not local.is_free(back[0], back[1], PASSING_CLEARANCE):
        return False
    direct = math.dist(goal, guest_spot) + math.dist(guest_spot, back)
    return routes.distance_to(*back) <= direct + WAY_BACK_DETOUR


def _mark_body(values: np.ndarray, around: Window, *, centre: Point, radius: float,
               margin: float) -> None:
    """Mark occupied (100) the cells of ``values`` (``around``'s) whose centres lie within
    ``radius`` of ``centre``. Only the square of cells within ``radius`` plus ``margin`` along
    each axis is measured: a cell farther along either axis is farther than ``radius`` whatever
    the other, since a hypotenuse is never shorter than either side, so the cells marked are
    those a measure of every cell marks, for a small part of the work."""
    x, y = centre
    cols = slice(*np.searchsorted(around.xs, (x - radius - margin, x + radius + margin)))
    rows = slice(*np.searchsorted(around.ys, (y - radius - margin, y + radius + margin)))
    square = values[rows, cols]
    square[np.hypot(around.xs[cols][None, :] - x, around.ys[rows][:, None] - y) <= radius] = 100
