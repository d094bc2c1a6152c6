"""SpotClearOfPeople: does the costmap show anyone beside the spot the robot is to stand on?

Through its ports on the blackboard, as the mission tree wires it: the spot, the map and
navigation's costmap, drawn as the simulator draws people on it (tests/fakes/maps.py).
"""

from __future__ import annotations

from typing import Any

import py_trees

from bt_servicesim.behaviours.conditions.spot_clear_of_people import SpotClearOfPeople
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from tests.fakes.leaves import wire
from tests.fakes.maps import costmap_of, open_room

Status = py_trees.common.Status
SPOT = Pose2D(7.0, 7.0, 0.0)


def check(**inputs: Any) -> SpotClearOfPeople:
    condition = wire(SpotClearOfPeople(name="spot_clear"), **inputs)
    condition.tick_once()
    return condition


def test_someone_standing_within_the_referees_reach_of_the_spot_makes_it_not_clear() -> None:
    grid = open_room()
    condition = check(spot=SPOT, occupancy=grid, costmap=costmap_of(grid, [(7.6, 7.6)]))
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == "1 people within 1.0 m of (7.0, 7.0): (7.6, 7.6)"


def test_people_just_beyond_it_leave_the_spot_clear() -> None:
    grid = open_room()
    condition = check(spot=SPOT, occupancy=grid,
                      costmap=costmap_of(grid, [(8.1, 7.0), (7.0, 5.8)]))
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == "nobody within 1.0 m of (7.0, 7.0)"


def test_the_distance_kept_is_a_parameter() -> None:
    grid = open_room()
    condition = wire(SpotClearOfPeople(name="spot_clear", keep=1.5), spot=SPOT, occupancy=grid,
                     costmap=costmap_of(grid, [(8.1, 7.0)]))
    condition.tick_once()
    assert condition.status == Status.FAILURE


def test_a_spot_against_a_wall_is_clear_the_walls_are_nobody() -> None:
    grid = open_room()
    condition = check(spot=Pose2D(0.7, 7.0, 0.0), occupancy=grid, costmap=costmap_of(grid, []))
    assert condition.status == Status.SUCCESS


def test_without_a_costmap_nobody_is_seen() -> None:
    condition = check(spot=SPOT, occupancy=open_room())
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == "no costmap: nobody seen"


def test_without_a_spot_it_fails_saying_so() -> None:
    grid = open_room()
    condition = check(occupancy=grid, costmap=costmap_of(grid, []))
    assert condition.status == Status.FAILURE
    assert condition.feedback_message.startswith("cannot check the spot")


def test_it_is_a_condition() -> None:
    assert kind_of(SpotClearOfPeople) == "Condition"


def test_the_guest_in_tow_stopping_behind_the_robot_at_its_goal_is_left_out() -> None:
    grid = open_room()
    history = RfidHistory()
    for t in range(11):  # the robot came along y = 7 to (7.4, 7); the guest stops 1.2 m back
        history.add(RfidReading(stamp=float(t), x=2.4 + 0.5 * t, y=7.0, names=frozenset()))
    robot = Pose2D(7.4, 7.0, 0.0)
    costmap = costmap_of(grid, [(6.2, 7.0)])  # 0.8 m short of the spot (7, 7)
    leading = check(spot=SPOT, occupancy=grid, costmap=costmap, guest_follows=True,
                    robot_pose=robot, rfid_history=history)
    assert leading.status == Status.SUCCESS
    alone = check(spot=SPOT, occupancy=grid, costmap=costmap, guest_follows=False,
                  robot_pose=robot, rfid_history=history)
    assert alone.status == Status.FAILURE


def test_with_the_guest_in_tow_someone_else_beside_the_spot_still_counts() -> None:
    grid = open_room()
    history = RfidHistory()
    for t in range(11):
        history.add(RfidReading(stamp=float(t), x=2.4 + 0.5 * t, y=7.0, names=frozenset()))
    robot = Pose2D(7.4, 7.0, 0.0)
    costmap = costmap_of(grid, [(6.2, 7.0), (7.2, 7.7)])
    condition = check(spot=SPOT, occupancy=grid, costmap=costmap, guest_follows=True,
                      robot_pose=robot, rfid_history=history)
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == "1 people within 1.0 m of (7.0, 7.0): (7.2, 7.7)"
