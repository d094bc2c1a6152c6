"""Where a dropped-off guest stands: clear of the doorway they were led in by.

The map is 16 x 12 m with a wall at x = 8 .. 8.2 and a 1.2 m door at y = 5.0 .. 6.2; the drop-off
box is the 3 x 3 m square inside the room that the door opens into, as the office's cafe has
its box. A guest left there stands for good, and a walker waits for as long as anyone stands in
its lane (1.5 m ahead): a guest just inside the door would hold the next walker in it.
"""

from __future__ import annotations

import math

import pytest

from bt_servicesim.planning.entrances import doorways_near
from bt_servicesim.planning.geometry import Box, Pose2D
from bt_servicesim.planning.goals import DOORWAY_KEEP, box_depth, drop_off_goal
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.rules import PEOPLE_LANE_LENGTH
from tests.fakes.maps import cells, fill, grid_message, open_room

BOX = Box(8.2, 4.0, 11.2, 7.0)
DOOR_CENTRE = (8.1, 5.6)


def room_with_door() -> OccupancyGrid2D:
    values = cells(16.0, 12.0)
    fill(values, 8.0, 0.0, 8.2, 5.0)
    fill(values, 8.0, 6.2, 8.2, 12.0)
    return OccupancyGrid2D.from_message(grid_message(values))


def test_the_door_beside_the_box_is_found_once() -> None:
    (door,) = doorways_near(room_with_door(), BOX)
    assert math.dist(door, DOOR_CENTRE) < 0.15


def test_a_door_farther_than_a_walker_held_by_the_guest_would_stand_is_not_counted() -> None:
    far = Box(8.2 + DOORWAY_KEEP + 0.3, 4.0, 11.2 + DOORWAY_KEEP + 0.3, 7.0)
    assert doorways_near(room_with_door(), far) == []


def test_a_box_in_open_space_or_a_corridor_has_no_doorway() -> None:
    assert doorways_near(open_room(), Box(5.5, 5.5, 8.5, 8.5)) == []
    values = cells(16.0, 12.0)
    fill(values, 0.0, 0.0, 16.0, 4.0)
    fill(values, 0.0, 5.6, 16.0, 12.0)  # a 1.6 m corridor: wider than a door
    corridor = OccupancyGrid2D.from_message(grid_message(values))
    assert doorways_near(corridor, Box(6.0, 4.0, 9.0, 5.6)) == []


@pytest.mark.parametrize("robot", [Pose2D(3.0, 10.0), Pose2D(3.0, 1.0), Pose2D(2.0, 5.6)])
def test_the_guest_is_left_deep_in_the_box_clear_of_the_door(robot: Pose2D) -> None:
    grid = room_with_door()
    anywhere = drop_off_goal(BOX, grid, robot)
    assert anywhere is not None
    # the deepest spot alone leaves the guest within a walker's lane of the door's middle
    assert math.dist(anywhere.guest_spot, DOOR_CENTRE) < PEOPLE_LANE_LENGTH + 0.6
    plan = drop_off_goal(BOX, grid, robot, doorways=doorways_near(grid, BOX))
    assert plan is not None
    assert math.dist(plan.guest_spot, DOOR_CENTRE) >= DOORWAY_KEEP - 0.1
    assert plan.margin >= 0.2  # inside, whichever way the guest strays by the usual errors
    assert box_depth(BOX, *plan.guest_spot) >= 0.5


def test_a_robot_already_inside_leaves_the_guest_clear_of_the_door_too() -> None:
    grid, robot = room_with_door(), Pose2D(9.0, 6.5, -math.pi / 2)  # the guest outside, west
    plan = drop_off_goal(BOX, grid, robot, doorways=doorways_near(grid, BOX))
    assert plan is not None
    assert math.dist(plan.guest_spot, DOOR_CENTRE) >= DOORWAY_KEEP - 0.1


def test_a_box_with_no_spot_clear_of_the_door_still_gets_its_deepest() -> None:
    grid, robot = room_with_door(), Pose2D(3.0, 10.0)
    small = Box(8.2, 4.8, 9.7, 6.3)  # 1.5 x 1.5 m: every spot lies within reach of the door
    plan = drop_off_goal(small, grid, robot, doorways=doorways_near(grid, small))
    assert plan == drop_off_goal(small, grid, robot)



def test_the_corners_of_thin_walls_are_no_doorways() -> None:
    """Two walls meeting at a corner face each other across a narrow gap, as a door's jambs
    do; the gap's middle lies near the corner, not a half-width from both walls. The office's
    thin walls make such gaps beside a box: here a room's 0.1 m east wall meets its north wall
    and, beyond it, the south wall of the room next door, as at the office's PrivateOfficeD."""
    values = cells(16.0, 12.0)
    fill(values, 11.0, 0.0, 11.1, 12.0)  # the room's east wall
    fill(values, 0.0, 9.0, 11.0, 9.1)  # its north wall
    fill(values, 11.1, 7.5, 16.0, 7.6)  # the south wall of the room next door
    rooms = OccupancyGrid2D.from_message(grid_message(values))
    assert doorways_near(rooms, Box(8.0, 6.0, 11.0, 9.0)) == []
