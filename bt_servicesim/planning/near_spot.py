"""As near to a waypoint as the way allows, when the waypoint itself cannot be reached.

A search waypoint is there for what its RFID disc covers. Navigation can fail to reach it for
good: two of the office's walkers who meet head-on in a doorway wait for each other for ever
(the original's ``TrajectoryActorPlugin``), and the room behind them is shut (hard seed 8 of the
evaluation: the guest stood in that room, 1.8 m from the corridor behind its wall). RFID hears
through walls, so most of what the waypoint covers can still be heard from the nearest spot the
robot can reach now: :func:`near_spot` finds it, with the people the costmap shows standing as
obstacles (they are why the waypoint failed) and keeping clear of them, on the way too: the
robot never parks beside someone, nor squeezes between two people who wait for each other (it
would stand there, held by them and holding them, as long as they do).

Pure: numpy and the occupancy grid, no ROS, no py_trees.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Point, Pose2D
from bt_servicesim.planning.give_way import local_grid_around
from bt_servicesim.planning.goals import ROBOT_CLEARANCE
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.rules import PERSON_APPROXIMATION_RADIUS, RFID_RANGE

__all__ = ["NEAR_PEOPLE_KEEP", "near_spot"]

NEAR_PEOPLE_KEEP = PERSON_APPROXIMATION_RADIUS + 0.25
"""Metres the spot keeps from everyone standing near: the referee's ghost cylinder for people
(0.75 m) and a person's body, so the robot waiting there is booked nothing."""
MARGIN = 1.0
"""Metres the map is taken beyond the robot and the target, for routes that swing wide."""


def near_spot(grid: OccupancyGrid2D, *, robot: Pose2D, target: Point,
              people: np.ndarray | None = None, reach: float = RFID_RANGE) -> Pose2D | None:
    """The spot nearest ``target`` (within ``reach`` of it) that the robot reaches now by a
    route keeping its centre :data:`NEAR_PEOPLE_KEEP` from everyone in ``people`` (n, 2), and
    as clear of them itself; it faces the target. None if no such spot lies within ``reach``."""
    people = np.zeros((0, 2)) if people is None else np.asarray(people, dtype=float).reshape(-1, 2)
    span = math.dist((robot.x, robot.y), target) + reach + MARGIN
    local = local_grid_around(grid, robot, span, people=people, heading=None,
                              person_body=NEAR_PEOPLE_KEEP - ROBOT_CLEARANCE)
    reachable = local.reachable_from(robot.x, robot.y, ROBOT_CLEARANCE)
    window = local.window(target[0] - reach, target[1] - reach,
                          target[0] + reach, target[1] + reach)
    if window.is_empty:
        return None
    xs, ys = np.meshgrid(window.xs, window.ys)
    to_target = np.hypot(xs - target[0], ys - target[1])
    allowed = reachable[window.rows, window.cols] & (to_target <= reach)
    for px, py in people:
        allowed &= np.hypot(xs - px, ys - py) >= NEAR_PEOPLE_KEEP
    if not allowed.any():
        return None
    best = np.unravel_index(int(np.argmin(np.where(allowed, to_target, np.inf))), xs.shape)
    x, y = float(xs[best]), float(ys[best])
    return Pose2D(x, y, math.atan2(target[1] - y, target[0] - x))
