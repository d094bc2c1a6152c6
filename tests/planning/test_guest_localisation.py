"""Locating the guest from RFID name lists and odometry, on synthetic maps and histories.

A robot drives a path on a small map; at every 0.1 sim s the RFID sensor hears the guest when
within 2.0 m of them, as the simulator's does. The estimate must land near the guest and the
approach goal must put the robot within pick-up reach of the true guest without crowding them,
on free space the robot can reach.
"""

from __future__ import annotations

import math

import numpy as np

from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import (
    GuestEstimate,
    RfidHistory,
    RfidReading,
    approach_goal,
    estimate_guest,
    locate_bystanders,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from tests.fakes.guest import GUEST, RFID_RANGE, check_approach, drive
from tests.fakes.maps import cells, fill, grid_message, open_room


def corridor() -> OccupancyGrid2D:
    """14 x 3 m: walls along y = 0 .. 0.1 and y = 2.9 .. 3.0, closed at both ends."""
    values = cells(14.0, 3.0)
    for wall in ((0, 0, 14.0, 0.1), (0, 2.9, 14.0, 3.0), (0, 0, 0.1, 3.0), (13.9, 0, 14.0, 3.0)):
        fill(values, *wall)
    return OccupancyGrid2D.from_message(grid_message(values))


# ============================================================================ the estimate
def test_a_guest_ahead_of_a_straight_approach_is_closed_in_on() -> None:
    grid, guest, history = open_room(), (9.0, 7.3), RfidHistory()
    now = drive(history, [(1.0, 7.0), (12.0, 7.0)], guest, stop_on_hearing=True)
    robot = Pose2D(history.latest.x, history.latest.y, 0.0)
    assert 1.8 < math.dist((robot.x, robot.y), guest) <= RFID_RANGE  # heard at the very edge

    estimate = estimate_guest(history, GUEST, grid, now)
    assert estimate is not None
    # heard once, at the edge: a crescent ahead, whose centroid lags the guest
    assert math.dist((estimate.x, estimate.y), guest) < 1.2
    assert estimate.x > robot.x + 0.5  # ahead, not behind where the robot heard nothing
    goal = approach_goal(estimate, grid, robot)
    check_approach(goal, grid, robot, guest)
    assert goal is not None and goal.x > robot.x


def test_a_guest_beside_a_wall_is_estimated_off_the_wall_and_approached_from_the_free_side(
) -> None:
    grid, guest, history = corridor(), (7.0, 0.45), RfidHistory()
    now = drive(history, [(1.0, 2.2), (13.0, 2.2)], guest, stop_on_hearing=True)
    robot = Pose2D(history.latest.x, history.latest.y, 0.0)

    estimate = estimate_guest(history, GUEST, grid, now)
    assert estimate is not None
    assert all(grid.is_free(x, y, 0.2) for x, y in estimate.spots)
    assert math.dist((estimate.x, estimate.y), guest) < 1.0
    goal = approach_goal(estimate, grid, robot)
    check_approach(goal, grid, robot, guest)
    assert goal is not None and goal.y > guest[1]  # the wall is on the other side


def test_a_guest_the_robot_drove_past_is_estimated_behind_it() -> None:
    # along a wall, so the guest's mirror image across the robot's line is inside the wall
    grid, guest, history = open_room(), (4.0, 3.0), RfidHistory()
    now = drive(history, [(1.0, 1.5), (11.0, 1.5)], guest)
    robot = Pose2D(11.0, 1.5, 0.0)

    estimate = estimate_guest(history, GUEST, grid, now)
    assert estimate is not None
    assert math.dist((estimate.x, estimate.y), guest) < 0.5
    goal = approach_goal(estimate, grid, robot)
    check_approach(goal, grid, robot, guest)
    assert goal is not None and goal.x < robot.x - 4.0


def test_only_the_latest_run_of_sightings_locates_a_guest_who_moved() -> None:
    grid, history = open_room(), RfidHistory()
    first = (3.0, 4.0)
    now = drive(history, [(2.0, 3.0), (4.0, 3.0), (4.0, 11.0)], first)  # heard near (3, 4) ...
    guest = (8.0, 12.0)  # ... then, after a pause, somewhere else, and heard passing by
    now = drive(history, [(4.0, 11.0), (10.0, 11.0), (10.0, 13.0), (7.0, 13.0)], guest,
                start=now + 10.0)

    estimate = estimate_guest(history, GUEST, grid, now)
    assert estimate is not None
    assert math.dist((estimate.x, estimate.y), guest) < 0.6
    assert math.dist((estimate.x, estimate.y), first) > 5.0


def test_a_waiting_guest_heard_on_two_passes_is_located_from_both() -> None:
    grid, guest, history = open_room(), (8.0, 12.0), RfidHistory()
    now = drive(history, [(4.0, 11.0), (12.0, 11.0), (12.0, 13.0), (9.0, 13.0)], guest)
    one_pass = estimate_guest(history, GUEST, grid, now)
    both = estimate_guest(history, GUEST, grid, now, sighting_gap=60.0)
    assert one_pass is not None and both is not None
    assert both.sightings > one_pass.sightings
    assert math.dist((both.x, both.y), guest) < 0.5
    assert len(both.spots) < len(one_pass.spots)


def test_no_estimate_without_a_recent_sighting() -> None:
    grid, history = open_room(), RfidHistory()
    assert estimate_guest(history, GUEST, grid, 0.0) is None
    now = drive(history, [(2.0, 2.0), (4.0, 2.0)], (3.0, 3.0))
    assert estimate_guest(history, "human_00000", grid, now) is None
    assert estimate_guest(history, GUEST, grid, now + 600.0) is None  # long forgotten


def test_a_robot_already_close_to_the_guest_stays_where_it_is() -> None:
    spots = np.array([[7.0 + dx, 7.0 + dy] for dx in (-0.2, 0.0, 0.2) for dy in (-0.2, 0.0, 0.2)])
    estimate = GuestEstimate(7.0, 7.0, spots, sightings=20)
    grid = open_room()
    assert approach_goal(estimate, grid, Pose2D(7.0, 5.6, math.pi / 2.0)) is None
    far = approach_goal(estimate, grid, Pose2D(7.0, 3.0, math.pi / 2.0))
    assert far is not None and 1.2 <= math.dist((far.x, far.y), (7.0, 7.0)) <= 1.6
    assert far.y < 7.0  # on the robot's side


def test_a_robot_inside_the_guests_personal_space_backs_off() -> None:
    spots = np.array([[7.0 + dx, 7.0 + dy] for dx in (-0.2, 0.0, 0.2) for dy in (-0.2, 0.0, 0.2)])
    estimate = GuestEstimate(7.0, 7.0, spots, sightings=20)
    goal = approach_goal(estimate, open_room(), Pose2D(7.0, 6.1, math.pi / 2.0))
    assert goal is not None and math.dist((goal.x, goal.y), (7.0, 7.0)) >= 1.2


def spots_around(x: float, y: float) -> GuestEstimate:
    spots = np.array([[x + dx, y + dy] for dx in (-0.2, 0.0, 0.2) for dy in (-0.2, 0.0, 0.2)])
    return GuestEstimate(x, y, spots, sightings=20)


def test_the_robot_stands_on_the_guests_side_towards_where_they_are_led() -> None:
    # the robot comes from the west; there is room to pass the guest at a distance
    estimate, grid, robot = spots_around(7.0, 7.0), open_room(), Pose2D(5.2, 7.0, 0.0)
    stay_west = approach_goal(estimate, grid, robot)
    assert stay_west is not None and stay_west.x < 7.0
    lead_east = approach_goal(estimate, grid, robot, leave_towards=(12.5, 7.0))
    assert lead_east is not None and lead_east.x > 7.0
    assert 1.1 <= math.dist((lead_east.x, lead_east.y), (7.0, 7.0)) <= 1.8
    lead_west = approach_goal(estimate, grid, robot, leave_towards=(1.5, 7.0))
    assert lead_west is not None and lead_west.x < 7.0


def test_the_robot_does_not_squeeze_past_a_waiting_guest_to_stand_beyond_them() -> None:
    # 1.6 m wide: passing the guest in the middle would come within 0.8 m of them
    values = cells(14.0, 2.0)
    for wall in ((0, 0, 14.0, 0.2), (0, 1.8, 14.0, 2.0), (0, 0, 0.1, 2.0), (13.9, 0, 14.0, 2.0)):
        fill(values, *wall)
    grid = OccupancyGrid2D.from_message(grid_message(values))
    goal = approach_goal(spots_around(7.0, 1.0), grid, Pose2D(4.8, 1.0, 0.0),
                         leave_towards=(12.5, 1.0))
    assert goal is not None and goal.x < 7.0 - 1.1


def test_the_robot_goes_round_the_block_to_stand_beyond_a_guest_blocking_a_corridor() -> None:
    # a ring of 1.6 m corridors round a 10 x 2 m block; the guest stands in the lower one
    values = cells(14.0, 6.0)
    for wall in ((0, 0, 14.0, 0.2), (0, 5.8, 14.0, 6.0), (0, 0, 0.2, 6.0), (13.8, 0, 14.0, 6.0),
                 (2.0, 2.0, 12.0, 4.0)):
        fill(values, *wall)
    grid = OccupancyGrid2D.from_message(grid_message(values))
    goal = approach_goal(spots_around(7.0, 1.0), grid, Pose2D(4.8, 1.0, 0.0),
                         leave_towards=(13.0, 1.0))
    assert goal is not None and goal.x > 7.0 + 1.1


def test_the_approach_keeps_off_walls_where_it_can() -> None:
    spots = np.array([[7.0 + dx, 1.5 + dy] for dx in (-0.2, 0.0, 0.2) for dy in (-0.2, 0.0, 0.2)])
    estimate = GuestEstimate(7.0, 1.5, spots, sightings=20)
    goal = approach_goal(estimate, corridor(), Pose2D(3.0, 0.5, 0.0))
    assert goal is not None and corridor().clearance(goal.x, goal.y) >= 0.6


def test_history_since_returns_the_recent_readings_in_order() -> None:
    history = RfidHistory(length=5)
    for k in range(8):
        history.add(RfidReading(float(k), 0.0, 0.0, frozenset()))
    assert len(history) == 5
    assert [reading.stamp for reading in history.since(5.0)] == [5.0, 6.0, 7.0]
    assert np.isclose(history.latest.stamp, 7.0)


# ============================================================================ bystanders
def test_the_approach_keeps_a_bystander_out_of_the_referees_one_metre() -> None:
    estimate, grid, robot = spots_around(7.0, 7.0), open_room(), Pose2D(7.0, 3.0, math.pi / 2)
    alone = approach_goal(estimate, grid, robot)
    assert alone is not None
    bystander = spots_around(alone.x, alone.y)  # an idler stands where the goal would be
    goal = approach_goal(estimate, grid, robot, bystanders=[bystander])
    assert goal is not None
    assert all(math.dist((goal.x, goal.y), spot) >= 1.0 for spot in bystander.spots)
    assert 1.1 <= math.dist((goal.x, goal.y), (7.0, 7.0)) <= 1.8  # still in reach, not crowding


def test_a_robot_beside_a_bystander_moves_off_though_the_guest_is_in_reach() -> None:
    estimate, grid, robot = spots_around(7.0, 7.0), open_room(), Pose2D(7.0, 5.6, math.pi / 2)
    assert approach_goal(estimate, grid, robot) is None  # close enough: it would stay
    goal = approach_goal(estimate, grid, robot, bystanders=[spots_around(6.6, 5.0)])
    assert goal is not None and math.dist((goal.x, goal.y), (6.6, 5.0)) >= 1.0 + 0.2


def test_bystanders_are_located_by_their_names_and_do_not_move_the_guests_estimate() -> None:
    # RFID lists at the pick-up name the guest and an idler standing 2 m from them
    grid, guest, idler = open_room(), (7.0, 7.0), (8.6, 5.8)
    crowded, alone = RfidHistory(), RfidHistory()
    now = 0.0
    path = [(float(x), 4.0) for x in np.arange(3.0, 7.0, 0.05)]  # east, then north: an L
    for robot in path + [(7.0, float(y)) for y in np.arange(4.0, 5.21, 0.05)]:
        names = {name for name, where in ((GUEST, guest), ("human_00042", idler))
                 if math.dist(robot, where) <= RFID_RANGE}
        crowded.add(RfidReading(now, *robot, frozenset(names)))
        alone.add(RfidReading(now, *robot, frozenset(names & {GUEST})))
        now += 0.1
    estimate = estimate_guest(crowded, GUEST, grid, now)
    assert estimate is not None and math.dist((estimate.x, estimate.y), guest) < 1.2
    by_itself = estimate_guest(alone, GUEST, grid, now)
    assert by_itself is not None and (estimate.x, estimate.y) == (by_itself.x, by_itself.y)
    others = locate_bystanders(crowded, GUEST, grid, now)
    assert len(others) == 1 and not locate_bystanders(alone, GUEST, grid, now)
    assert min(math.dist(spot, idler) for spot in others[0].spots) < 0.2
    assert min(math.dist(spot, guest) for spot in estimate.spots) < 0.2
