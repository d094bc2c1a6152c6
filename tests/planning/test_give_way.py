"""Where the robot gives way: the corridor deadlock the office's walkers make, drawn small.

The map is a 1.6 m corridor along x (y = 4.0 .. 5.6) with a room to the north behind a 1.1 m
door (x = 9.45 .. 10.55) and a cubicle-like alcove 1.5 m wide to the south. The robot stands in
the corridor at x = 10 facing west (where a walker waits for it), having come from the east.
Every expected figure follows from those walls and the rules: a walker's lane is 0.6 m either
side of its way, and a guest in tow stops 1.2 m short of the robot along its route.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.give_way import (
    DOOR_LANE_OFFSET,
    GIVE_WAY_OFFSET,
    GUEST_STOP_ROOM,
    doorway,
    give_way_spot,
    passage_axis,
    passage_width,
    people_held_up,
    recent_trail,
    without_the_guest,
)
from bt_servicesim.planning.goals import ROBOT_CLEARANCE
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from bt_servicesim.planning.rules import FOLLOW_GAP, PEOPLE_LANE_HALF_WIDTH, PEOPLE_LANE_LENGTH
from tests.fakes.maps import cells, fill, grid_message

CORRIDOR = (4.0, 5.6)
DOOR = (9.45, 10.55)
ROBOT = Pose2D(10.0, 4.8, math.pi)  # facing west, the walker ahead
TRAIL = [(x, 4.8) for x in np.arange(40.0, 10.0, -0.1)]  # came from the east, oldest first


def office(*, alcove: bool = True, room: bool = True) -> OccupancyGrid2D:
    """24 x 12 m of wall with the corridor, the room north of the door and the alcove south."""
    values = cells(24.0, 12.0)
    fill(values, 0.0, 0.0, 24.0, 12.0)
    fill(values, 0.0, CORRIDOR[0], 24.0, CORRIDOR[1], value=0)
    if room:
        fill(values, 7.0, 5.8, 13.0, 9.0, value=0)  # the room: 6 x 3.2 m
        fill(values, DOOR[0], CORRIDOR[1], DOOR[1], 5.8, value=0)  # the door through the wall
    if alcove:
        fill(values, 15.0, 1.0, 16.5, CORRIDOR[0], value=0)  # 1.5 m wide, 3 m deep
    return OccupancyGrid2D.from_message(grid_message(values))


def trail() -> np.ndarray:
    return recent_trail(TRAIL)


def guest_stop(grid: OccupancyGrid2D, spot: Pose2D) -> tuple[float, float]:
    """Where a guest trailing the robot's route to ``spot`` stops."""
    routes = grid.routes_from(ROBOT.x, ROBOT.y, ROBOT_CLEARANCE)
    assert routes is not None
    path = routes.path_back_from(spot.x, spot.y, FOLLOW_GAP)
    return float(path[-1, 0]), float(path[-1, 1])


def test_without_a_guest_the_robot_steps_into_the_nearest_room_off_the_lane() -> None:
    grid = office()
    spot = give_way_spot(grid, robot=ROBOT, trail=trail())
    assert spot is not None
    assert 7.0 < spot.x < 13.0 and spot.y > 5.8, spot  # in the room, not in the corridor
    assert spot.y - 4.8 >= GIVE_WAY_OFFSET - 0.05  # off the walker's lane with the robot's width
    assert GIVE_WAY_OFFSET > PEOPLE_LANE_HALF_WIDTH
    assert grid.is_free(spot.x, spot.y, ROBOT_CLEARANCE)
    assert math.isclose(spot.yaw, math.atan2(ROBOT.y - spot.y, ROBOT.x - spot.x))


def test_with_a_guest_in_tow_the_guest_stops_in_the_room_not_in_the_door() -> None:
    grid = office()
    alone = give_way_spot(grid, robot=ROBOT, trail=trail())
    spot = give_way_spot(grid, robot=ROBOT, trail=trail(), guest_follows=True)
    assert alone is not None and spot is not None
    gx, gy = guest_stop(grid, spot)
    assert gy > 5.8 + 0.5, (gx, gy)  # inside the room, clear of the door
    assert grid.clearance(gx, gy) >= GUEST_STOP_ROOM - grid.resolution
    assert gy - CORRIDOR[1] > PEOPLE_LANE_HALF_WIDTH  # the guest is out of the lane too
    # Neither the robot nor its guest waits on the door's axis, where a walker bound for the
    # room walks in.
    door_x = sum(DOOR) / 2
    assert abs(spot.x - door_x) >= DOOR_LANE_OFFSET - grid.resolution
    assert abs(gx - door_x) >= DOOR_LANE_OFFSET - 2 * grid.resolution


def test_a_spot_in_a_room_keeps_off_the_doors_axis() -> None:
    spot = give_way_spot(office(alcove=False), robot=ROBOT, trail=trail())
    assert spot is not None and spot.y > 5.8
    assert abs(spot.x - sum(DOOR) / 2) >= DOOR_LANE_OFFSET - 0.1


def test_the_corridor_axis_is_a_lane_even_where_the_robot_never_drove() -> None:
    """Between two walkers, with no trail along the corridor, the robot still leaves it."""
    grid = office(room=False)
    robot = Pose2D(14.0, 4.8, -math.pi / 2)  # facing the corridor's wall, as after a turn
    spot = give_way_spot(grid, robot=robot, trail=np.zeros((0, 2)))
    assert spot is not None
    assert spot.y <= 4.8 - GIVE_WAY_OFFSET + 0.05 and 15.0 < spot.x < 16.5, spot


@pytest.mark.parametrize(("x", "y"), [(10.0, 4.8), (5.0, 4.4), (20.0, 5.2)])
def test_the_passage_axis_runs_along_the_corridor(x: float, y: float) -> None:
    angle = passage_axis(office(), x, y)
    assert min(angle, math.pi - angle) <= math.radians(5.0)


def test_a_narrow_alcove_will_do_alone_but_not_with_a_guest() -> None:
    grid = office(room=False)
    spot = give_way_spot(grid, robot=ROBOT, trail=trail())
    assert spot is not None and 15.0 < spot.x < 16.5 and spot.y < CORRIDOR[0], spot
    assert give_way_spot(grid, robot=ROBOT, trail=trail(), guest_follows=True) is None


def test_the_way_ahead_and_the_trail_itself_are_no_place_to_wait() -> None:
    grid = office(alcove=False, room=False)  # nothing but the corridor
    assert give_way_spot(grid, robot=ROBOT, trail=trail()) is None


@pytest.mark.parametrize("limit", [2.0, 4.0])
def test_no_spot_further_by_route_than_the_limit(limit: float) -> None:
    grid = office(room=False)  # the alcove's mouth is 5 m east of the robot
    assert give_way_spot(grid, robot=ROBOT, trail=trail(), max_route=limit) is None


def test_the_trail_is_kept_newest_first_thinned_and_cut_to_length() -> None:
    points = [(float(x), 0.0) for x in np.arange(0.0, 50.0, 0.05)]
    kept = recent_trail(points, length=10.0, step=0.5)
    assert tuple(kept[0]) == points[-1]
    assert np.all(np.diff(kept[:, 0]) < 0)
    assert np.all(np.abs(np.diff(kept[:, 0])) >= 0.5 - 1e-9)
    assert kept[0, 0] - kept[-1, 0] <= 10.0
    assert recent_trail([]).shape == (0, 2)


@pytest.mark.parametrize(("x", "y"), [(10.0, 5.7), (9.7, 5.65), (10.3, 5.75)])
def test_a_doorway_is_found_between_its_jambs(x: float, y: float) -> None:
    door = doorway(office(), x, y)
    assert door is not None
    assert math.isclose(door.x, 10.0, abs_tol=0.06) and 5.6 <= door.y <= 5.8
    assert math.isclose(door.width, DOOR[1] - DOOR[0], abs_tol=0.1)
    assert math.isclose(door.axis, math.pi / 2, abs_tol=0.05)


@pytest.mark.parametrize(("x", "y"), [(10.0, 4.8), (14.7, 4.3), (15.75, 2.5)])
def test_a_corridor_a_corner_or_an_alcove_is_no_doorway(x: float, y: float) -> None:
    assert doorway(office(), x, y) is None


# ------------------------------------------------------------------ people the robot can see
WALKER = (8.9, 4.8)  # in the corridor, 1.1 m west of the robot: held up by it
IN_THE_DOOR = (10.0, 5.8)


def straight_line_guest_stop(grid: OccupancyGrid2D, robot: Pose2D,
                             spot: Pose2D) -> tuple[float, float]:
    """Where a guest trailing the robot's route to ``spot`` stops: the first point back along
    the route a following gap from the spot in a straight line."""
    routes = grid.routes_from(robot.x, robot.y, ROBOT_CLEARANCE)
    assert routes is not None
    back = routes.path_back_from(spot.x, spot.y, 30.0)
    far = np.flatnonzero(np.hypot(back[:, 0] - spot.x, back[:, 1] - spot.y) >= FOLLOW_GAP)
    x, y = back[far[0]] if far.size else (robot.x, robot.y)
    return float(x), float(y)


def test_the_spot_and_the_guests_stop_keep_clear_of_everyone_standing_near() -> None:
    grid = office()
    first = give_way_spot(grid, robot=ROBOT, trail=trail(), guest_follows=True,
                          people=np.array([WALKER]))
    assert first is not None
    idler = (first.x - 0.9, first.y + 0.9)  # someone standing in the corner beside that spot
    spot = give_way_spot(grid, robot=ROBOT, trail=trail(), guest_follows=True,
                         people=np.array([WALKER, idler]))
    assert spot is not None
    for person in (WALKER, idler):
        assert math.dist((spot.x, spot.y), person) > PEOPLE_LANE_LENGTH
        assert math.dist(straight_line_guest_stop(grid, ROBOT, spot), person) > (
            PEOPLE_LANE_LENGTH)


def test_no_route_to_the_spot_runs_through_someone_standing_in_the_door() -> None:
    grid = office()
    assert give_way_spot(grid, robot=ROBOT, trail=trail()).y > 5.8  # the room, with nobody there
    spot = give_way_spot(grid, robot=ROBOT, trail=trail(), people=np.array([IN_THE_DOOR]))
    assert spot is not None and 15.0 < spot.x < 16.5 and spot.y < CORRIDOR[0], spot  # the alcove


def test_in_a_room_whose_door_a_walker_holds_the_lanes_give_way_not_the_people() -> None:
    """The robot and its guest stepped into the room; a walker bound for it stopped in the door
    for the guest. Every spot in the room is near the robot's trail (through that door): only
    the people can say where to wait."""
    grid = office(alcove=False)
    robot = Pose2D(9.4, 6.9, math.pi)
    came = [*TRAIL, *[(10.0, y) for y in np.arange(4.8, 6.6, 0.1)], (9.7, 6.75), (9.4, 6.9)]
    walker = (10.0, 5.9)
    spot = give_way_spot(grid, robot=robot, trail=recent_trail(came), guest_follows=True,
                         people=np.array([walker]))
    assert spot is not None and spot.y > 5.8  # in the room
    assert math.dist((spot.x, spot.y), walker) > PEOPLE_LANE_LENGTH
    assert math.dist(straight_line_guest_stop(grid, robot, spot), walker) > PEOPLE_LANE_LENGTH


def test_the_guest_is_whoever_stands_on_the_trail_the_robot_passed_last() -> None:
    came = recent_trail([*TRAIL, (9.9, 4.8)])
    guest, walker_ahead, walker_behind = (11.2, 4.85), WALKER, (16.0, 4.7)
    kept = without_the_guest(np.array([walker_ahead, guest, walker_behind]), robot=ROBOT,
                             trail=came)
    assert kept.tolist() == [list(walker_ahead), list(walker_behind)]
    nobody_on_it = np.array([walker_ahead, (10.0, 7.0)])
    assert without_the_guest(nobody_on_it, robot=ROBOT, trail=came).tolist() == (
        nobody_on_it.tolist())
    assert without_the_guest(np.zeros((0, 2)), robot=ROBOT, trail=came).shape == (0, 2)


def test_people_held_up_are_those_within_a_lanes_length_nearest_first() -> None:
    people = np.array([(11.4, 4.8), (10.0, 5.9), (12.0, 4.8), (10.0, 2.0)])
    near = people_held_up(people, robot=ROBOT)
    assert near.tolist() == [[10.0, 5.9], [11.4, 4.8]]
    assert people_held_up(people, robot=ROBOT, reach=1.0).shape == (0, 2)
    assert people_held_up(np.zeros((0, 2)), robot=ROBOT).shape == (0, 2)


def test_a_spot_to_step_to_before_standing_is_looked_for_only_within_its_route() -> None:
    """Someone stands a metre from the robot in the corridor: the spot off the lanes within a
    few metres is the room through the door beside it; within a metre there is none."""
    grid = office()
    near = np.array([(9.0, 4.8)])
    spot = give_way_spot(grid, robot=ROBOT, trail=trail(), people=near, max_route=5.0)
    assert spot is not None and spot.y > 5.8, spot  # the room
    assert math.dist((spot.x, spot.y), (9.0, 4.8)) > PEOPLE_LANE_LENGTH
    assert give_way_spot(grid, robot=ROBOT, trail=trail(), people=near, max_route=1.0) is None


@pytest.mark.parametrize(("x", "y", "low", "high"), [
    (3.0, 4.8, 1.5, 1.7),  # mid-corridor, 1.6 m between its walls
    (3.0, 4.3, 1.5, 1.7),  # off its middle: the same corridor
    (8.0, 7.4, 3.1, 3.3),  # in the room, 3.2 m deep, away from its door
])
def test_the_passage_width_is_the_shortest_free_span_through_a_point(
        x: float, y: float, low: float, high: float) -> None:
    assert low <= passage_width(office(alcove=False), x, y) <= high


def test_a_blocked_point_stands_in_no_passage() -> None:
    assert passage_width(office(), 3.0, 2.0) == 0.0
