"""Where the robot drops the guest off when others stand near the drop-off box.

The maps are the room of ``test_entrances`` (16 x 12 m, a wall at x = 8 .. 8.2 with a 1.2 m door
at y = 5.0 .. 6.2, the 3 x 3 m drop-off box inside it) and the corridor of ``test_way_out``.
Others stand where the costmap shows them: an idler, or two walkers waiting for each other, stay
for good. A goal beside one of them books the robot for every second it waits there, and a guest
left beside one can shut the robot's way out.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.goals import (
    PEOPLE_KEEP,
    ROBOT_CLEARANCE,
    TrailingPlan,
    drop_off_goal,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.way_out import way_back_open, way_back_point
from tests.fakes.maps import cells, fill, grid_message
from tests.planning.test_way_out import BOX as CORRIDOR_BOX
from tests.planning.test_way_out import ROBOT as CORRIDOR_ROBOT
from tests.planning.test_way_out import corridor

BOX = Box(8.2, 4.0, 11.2, 7.0)
ROBOT = Pose2D(3.0, 5.6)


def room_with_door() -> OccupancyGrid2D:
    values = cells(16.0, 12.0)
    fill(values, 8.0, 0.0, 8.2, 5.0)
    fill(values, 8.0, 6.2, 8.2, 12.0)
    fill(values, 12.2, 0.0, 16.0, 12.0)  # the room's east wall: 4 m deep
    return OccupancyGrid2D.from_message(grid_message(values))


def clearance(point: tuple[float, float], people: np.ndarray) -> float:
    return float(np.min(np.hypot(people[:, 0] - point[0], people[:, 1] - point[1])))


def test_someone_standing_at_the_best_goal_moves_the_goal_and_the_guest_clear_of_them() -> None:
    grid = room_with_door()
    alone = drop_off_goal(BOX, grid, ROBOT)
    assert alone is not None
    people = np.array([[alone.goal.x, alone.goal.y]])
    plan = drop_off_goal(BOX, grid, ROBOT, people=people)
    assert plan is not None
    assert clearance((plan.goal.x, plan.goal.y), people) >= PEOPLE_KEEP
    assert clearance(plan.guest_spot, people) >= PEOPLE_KEEP
    assert plan.margin >= 0.2  # still well inside the box


def test_the_way_back_counts_the_people_standing_as_it_counts_the_guest() -> None:
    grid = corridor()  # test_way_out's: the guest left in the corridor's middle shuts it
    alone = drop_off_goal(CORRIDOR_BOX, grid, CORRIDOR_ROBOT)
    assert alone is not None and alone.guest_spot[1] < 5.0  # the guest by the south wall
    someone = np.array([[9.0, 5.2]])  # stands by the north wall, where the way back ran
    routes = grid.routes_from(CORRIDOR_ROBOT.x, CORRIDOR_ROBOT.y, ROBOT_CLEARANCE)
    assert routes is not None

    def way_back(plan: TrailingPlan) -> bool:
        back = way_back_point(routes, plan.guest_spot)
        return back is not None and way_back_open(
            grid, goal=(plan.goal.x, plan.goal.y), guest_spot=plan.guest_spot, back=back,
            people=someone)

    assert not way_back(alone)
    plan = drop_off_goal(CORRIDOR_BOX, grid, CORRIDOR_ROBOT, people=someone)
    assert plan is not None
    assert way_back(plan)
    assert plan.guest_spot[1] > 5.0  # the guest by the north wall, the way back south


def test_a_box_full_of_people_still_gets_a_goal_the_people_are_given_up_before_the_way_back(
) -> None:
    grid = room_with_door()
    xs, ys = np.meshgrid(np.arange(8.6, 11.3, 0.9), np.arange(4.3, 7.0, 0.9))
    crowd = np.column_stack([xs.ravel(), ys.ravel()])
    plan = drop_off_goal(BOX, grid, ROBOT, people=crowd)
    assert plan is not None
    assert math.dist((plan.goal.x, plan.goal.y), (ROBOT.x, ROBOT.y)) > 4.0


def test_nobody_near_plans_as_without_people() -> None:
    grid = room_with_door()
    assert drop_off_goal(BOX, grid, ROBOT, people=np.zeros((0, 2))) == drop_off_goal(
        BOX, grid, ROBOT)
