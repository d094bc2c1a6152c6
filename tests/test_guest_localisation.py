"""Locating the guest from RFID name lists and odometry, on synthetic maps and histories.

A robot drives a path on a small map; at every 0.1 sim s the RFID sensor hears the guest when
within 2.0 m of them, as the simulator's does. The estimate must land near the guest and the
approach goal must put the robot within pick-up reach of the true guest without crowding them,
on free space the robot can reach.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import py_trees
import pytest
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.guest_approach_goal import GuestApproachGoal
from bt_servicesim.behaviours.actions.guest_steadily_in_range import GuestSteadilyInRange
from bt_servicesim.behaviours.actions.record_rfid_readings import RecordRfidReadings
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import (
    GuestEstimate,
    RfidHistory,
    RfidReading,
    approach_goal,
    estimate_guest,
)
from bt_servicesim.planning.occupancy import OccupancyGrid2D
from tests.mission_script import ManualClock
from tests.test_leaf_goals import open_room
from tests.test_occupancy import cells, fill, grid_message

Status = py_trees.common.Status
GUEST = "human_12345"
OTHER = "human_99999"
RANGE = 2.0
SPEED = 0.5  # m/s, the robot's navigation limit
PERIOD = 0.1  # s between RFID messages


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    Blackboard.clear()
    yield
    Blackboard.clear()


def corridor() -> OccupancyGrid2D:
    """14 x 3 m: walls along y = 0 .. 0.1 and y = 2.9 .. 3.0, closed at both ends."""
    values = cells(14.0, 3.0)
    for wall in ((0, 0, 14.0, 0.1), (0, 2.9, 14.0, 3.0), (0, 0, 0.1, 3.0), (13.9, 0, 14.0, 3.0)):
        fill(values, *wall)
    return OccupancyGrid2D.from_message(grid_message(values))


def drive(history: RfidHistory, path: list[tuple[float, float]], guest: tuple[float, float],
          *, start: float = 0.0, stop_on_hearing: bool = False) -> float:
    """Drive ``path`` (straight legs) at SPEED, hearing the guest within RANGE; returns the time.

    With ``stop_on_hearing`` the drive ends at the first reading naming the guest, as
    exploration does."""
    now = start
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        steps = max(1, round(math.dist((x0, y0), (x1, y1)) / (SPEED * PERIOD)))
        for k in range(steps + 1):
            x, y = x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps
            heard = math.dist((x, y), guest) <= RANGE
            history.add(RfidReading(now, x, y, frozenset({GUEST, OTHER} if heard else {OTHER})))
            now += PERIOD
            if heard and stop_on_hearing:
                return now
    return now


def stand(history: RfidHistory, at: tuple[float, float], guest: tuple[float, float],
          seconds: float, start: float) -> float:
    return drive(history, [at, at], guest, start=start) + seconds


def check_approach(goal: Pose2D | None, grid: OccupancyGrid2D, robot: Pose2D,
                   guest: tuple[float, float]) -> None:
    assert goal is not None
    to_guest = math.dist((goal.x, goal.y), guest)
    assert 0.75 < to_guest <= 1.8, f"goal {goal} is {to_guest:.2f} m from the guest"
    assert grid.is_free(goal.x, goal.y, 0.35)
    assert grid.reachable_from(robot.x, robot.y, 0.35)[grid.world_to_cell(goal.x, goal.y)]
    facing = math.atan2(guest[1] - goal.y, guest[0] - goal.x)
    assert abs(math.remainder(goal.yaw - facing, 2.0 * math.pi)) < math.pi / 2.0


# ============================================================================ the estimate
def test_a_guest_ahead_of_a_straight_approach_is_closed_in_on() -> None:
    grid, guest, history = open_room(), (9.0, 7.3), RfidHistory()
    now = drive(history, [(1.0, 7.0), (12.0, 7.0)], guest, stop_on_hearing=True)
    robot = Pose2D(history.latest.x, history.latest.y, 0.0)
    assert 1.8 < math.dist((robot.x, robot.y), guest) <= RANGE  # heard at the very edge

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


# ============================================================================ behaviours
def wire(behaviour: Any, clock: ManualClock, **inputs: Any) -> Any:
    ports = {**behaviour.input_ports(), **behaviour.output_ports()}
    behaviour.setup_ports(port_remappings={port: f"/{port}" for port in ports})
    behaviour.setup(node=clock)
    for key, value in inputs.items():
        Blackboard.set(f"/{key}", value)
    return behaviour


def test_each_rfid_message_is_recorded_once_and_silence_as_nobody_in_range() -> None:
    clock = ManualClock()
    recorder = wire(RecordRfidReadings(), clock, actors_in_range=[GUEST], rfid_age=0.02,
                    robot_pose=Pose2D(1.0, 2.0))
    recorder.tick_once()
    clock.advance(0.05)
    Blackboard.set("/rfid_age", 0.07)  # the same message, a tick later
    recorder.tick_once()
    history = Blackboard.get("/rfid_history")
    assert [reading.names for reading in history] == [frozenset({GUEST})]
    assert (history.latest.x, history.latest.y) == (1.0, 2.0)

    clock.advance(0.05)
    Blackboard.set("/rfid_age", 0.0)  # a new message
    recorder.tick_once()
    assert len(history) == 2
    for _ in range(5):  # the sensor falls silent; the list on the blackboard is stale
        clock.advance(0.1)
        Blackboard.set("/rfid_age", Blackboard.get("/rfid_age") + 0.1)
        recorder.tick_once()
    assert [reading.names for reading in history][-2:] == [frozenset(), frozenset()]
    assert recorder.status == Status.SUCCESS
    assert Blackboard.get("/rfid_history") is history


def test_the_recorder_waits_quietly_for_odometry() -> None:
    recorder = wire(RecordRfidReadings(), ManualClock(), actors_in_range=[], rfid_age=0.0)
    recorder.tick_once()
    assert recorder.status == Status.SUCCESS
    assert len(Blackboard.get("/rfid_history")) == 0


def steady_check(readings: list[bool], clock: ManualClock) -> Status:
    """Tick GuestSteadilyInRange while readings come every 0.1 s (None: a lost message)."""
    history = RfidHistory()
    check = wire(GuestSteadilyInRange(), clock, guest_name=GUEST, rfid_history=history)
    check.tick_once()
    for heard in readings:
        clock.advance(PERIOD)
        if heard is not None:
            names = frozenset({GUEST} if heard else set())
            history.add(RfidReading(clock.nanoseconds / 1e9, 0.0, 0.0, names))
        check.tick_once()
        if check.status != Status.RUNNING:
            break
    return check.status


def test_the_pick_up_waits_for_half_a_second_of_readings_all_naming_the_guest() -> None:
    assert steady_check([True] * 3, ManualClock()) == Status.RUNNING
    assert steady_check([True] * 6, ManualClock()) == Status.SUCCESS
    assert steady_check([True, None, True, None, True, True], ManualClock()) == Status.SUCCESS


def test_a_guest_dropping_out_of_range_or_silence_fails_the_check() -> None:
    assert steady_check([True, True, False, True, True, True], ManualClock()) == Status.FAILURE
    assert steady_check([None] * 40, ManualClock()) == Status.FAILURE


def test_the_approach_goal_behaviour_writes_a_goal_near_the_estimate() -> None:
    grid, guest, history, clock = open_room(), (9.0, 7.3), RfidHistory(), ManualClock()
    now = drive(history, [(1.0, 7.0), (12.0, 7.0)], guest, start=1.0, stop_on_hearing=True)
    clock.advance(now - 1.0)
    robot = Pose2D(history.latest.x, history.latest.y, 0.0)
    behaviour = wire(GuestApproachGoal(), clock, guest_name=GUEST, rfid_history=history,
                     occupancy=grid, robot_pose=robot)
    behaviour.tick_once()
    assert behaviour.status == Status.SUCCESS
    check_approach(Blackboard.get("/goal"), grid, robot, guest)


def test_the_approach_goal_behaviour_fails_without_a_sighting() -> None:
    behaviour = wire(GuestApproachGoal(), ManualClock(), guest_name=GUEST,
                     rfid_history=RfidHistory(), occupancy=open_room(),
                     robot_pose=Pose2D(3.0, 3.0))
    behaviour.tick_once()
    assert behaviour.status == Status.FAILURE
    assert "not heard" in behaviour.feedback_message


def test_history_since_returns_the_recent_readings_in_order() -> None:
    history = RfidHistory(length=5)
    for k in range(8):
        history.add(RfidReading(float(k), 0.0, 0.0, frozenset()))
    assert len(history) == 5
    assert [reading.stamp for reading in history.since(5.0)] == [5.0, 6.0, 7.0]
    assert np.isclose(history.latest.stamp, 7.0)
