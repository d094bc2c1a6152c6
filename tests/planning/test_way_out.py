"""Whether the robot can leave a drop-off spot past the guest it leaves standing there.

The map is a 1.8 m corridor along x (y = 4.0 .. 5.8), about as wide as the office's corridor
north of its cubicles, with the robot arriving from the west along its south wall. The drop-off
box spans the corridor at x = 9 .. 11. A guest left in the middle of it shuts the corridor for
good (their body, where they stop give or take 0.25 m, and the robot's room round them leave
no way on either side); a guest left near a wall leaves the robot a way back beside them. With
``loop``, a second corridor north, joined to the first at both ends, makes a block the robot
could drive round: a way too long to count.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.goals import ROBOT_CLEARANCE, box_depth, drop_off_goal
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.rules import FOLLOW_GAP
from bt_servicesim.planning.way_out import way_back_open, way_back_point
from tests.fakes.maps import cells, fill, grid_message

CORRIDOR = (4.0, 5.8)
BOX = Box(9.0, 3.9, 11.0, 5.7)
ROBOT = Pose2D(1.0, 4.4, 0.0)  # beside the south wall
BACK = (7.0, 4.8)  # on the arrival route, 2.5 m before the box's middle


def corridor(*, loop: bool = False) -> OccupancyGrid2D:
    values = cells(20.0, 12.0)
    fill(values, 0.0, 0.0, 20.0, 12.0)
    fill(values, 0.5, CORRIDOR[0], 19.5, CORRIDOR[1], value=0)
    if loop:
        fill(values, 0.5, 8.0, 19.5, 9.6, value=0)
        fill(values, 0.5, CORRIDOR[1], 2.1, 8.0, value=0)
        fill(values, 17.9, CORRIDOR[1], 19.5, 8.0, value=0)
    return OccupancyGrid2D.from_message(grid_message(values))


def test_a_guest_in_the_middle_of_the_corridor_shuts_the_way_back() -> None:
    middle = (10.0, sum(CORRIDOR) / 2.0)
    assert not way_back_open(corridor(), goal=(middle[0] + FOLLOW_GAP, middle[1]),
                             guest_spot=middle, back=BACK, guest_spread=0.25)


def test_a_guest_near_a_wall_leaves_the_way_back_beside_them() -> None:
    near_wall = (10.0, CORRIDOR[0] + ROBOT_CLEARANCE)
    assert way_back_open(corridor(), goal=(near_wall[0] + FOLLOW_GAP, near_wall[1]),
                         guest_spot=near_wall, back=BACK)


def test_the_guests_spread_can_shut_a_way_that_is_open_for_the_spot_itself() -> None:
    near_wall = (10.0, CORRIDOR[0] + ROBOT_CLEARANCE)
    assert not way_back_open(corridor(), goal=(near_wall[0] + FOLLOW_GAP, near_wall[1]),
                             guest_spot=near_wall, back=BACK, guest_spread=0.8)


def test_someone_else_standing_beside_the_guest_shuts_the_way_back() -> None:
    near_wall = (10.0, CORRIDOR[0] + ROBOT_CLEARANCE)
    assert not way_back_open(corridor(), goal=(near_wall[0] + FOLLOW_GAP, near_wall[1]),
                             guest_spot=near_wall, back=BACK, people=np.array([(10.0, 5.3)]))


def test_a_way_round_a_block_is_not_a_way_back() -> None:
    middle = (10.0, sum(CORRIDOR) / 2.0)
    assert not way_back_open(corridor(loop=True), goal=(middle[0] + FOLLOW_GAP, middle[1]),
                             guest_spot=middle, back=BACK, guest_spread=0.25)


def test_the_way_back_point_lies_on_the_arrival_route_before_the_spot() -> None:
    routes = corridor().routes_from(ROBOT.x, ROBOT.y, ROBOT_CLEARANCE)
    assert routes is not None
    back = way_back_point(routes, (10.0, 4.8))
    assert back is not None
    assert 2.2 <= math.dist(back, (10.0, 4.8)) <= 2.8
    assert back[0] < 10.0


def test_the_drop_off_goal_leaves_the_guest_where_the_robot_can_get_back_past_them() -> None:
    grid = corridor()
    plan = drop_off_goal(BOX, grid, ROBOT)
    assert plan is not None
    assert box_depth(BOX, *plan.guest_spot) > 0.0
    routes = grid.routes_from(ROBOT.x, ROBOT.y, ROBOT_CLEARANCE)
    assert routes is not None
    back = way_back_point(routes, plan.guest_spot)
    assert back is not None
    assert way_back_open(grid, goal=(plan.goal.x, plan.goal.y), guest_spot=plan.guest_spot,
                         back=back)
    # the deepest spot, the box's middle, would have shut the corridor
    assert abs(plan.guest_spot[1] - sum(CORRIDOR) / 2.0) > 0.25


@pytest.mark.parametrize("seed", range(30))
def test_a_body_marks_the_cells_a_measure_of_every_cell_marks(seed: int) -> None:
    from bt_servicesim.planning.way_out import _mark_body

    random = np.random.default_rng(seed)
    grid = corridor()
    x, y = float(random.uniform(2.0, 18.0)), float(random.uniform(2.0, 10.0))
    around = grid.window(x - 4.0, y - 4.0, x + 4.0, y + 4.0)
    values = np.zeros((around.ys.size, around.xs.size), dtype=np.int16)
    body = (float(random.uniform(x - 4.5, x + 4.5)), float(random.uniform(y - 4.5, y + 4.5)))
    radius = float(random.uniform(0.05, 1.0))
    _mark_body(values, around, centre=body, radius=radius, margin=grid.resolution)
    every_cell = np.hypot(around.xs[None, :] - body[0], around.ys[:, None] - body[1]) <= radius
    assert np.array_equal(values == 100, every_cell)
