"""PeopleHeldUp: would the robot, standing where it is, hold up someone the costmap shows?

Through its ports on the blackboard, as the mission tree wires it: the robot's pose, the map
and navigation's costmap, drawn as the simulator draws people on it (tests/fakes/maps.py).
"""

from __future__ import annotations

from typing import Any

import py_trees

from bt_servicesim.behaviours.conditions.people_held_up import PeopleHeldUp
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from tests.fakes.leaves import wire
from tests.fakes.maps import costmap_of, open_room

Status = py_trees.common.Status
ROBOT = Pose2D(7.0, 7.0, 0.0)


def check(**inputs: Any) -> PeopleHeldUp:
    condition = wire(PeopleHeldUp(name="held_up"), **inputs)
    condition.tick_once()
    return condition


def test_someone_standing_a_metre_in_front_is_held_up() -> None:
    grid = open_room()
    condition = check(robot_pose=ROBOT, occupancy=grid, costmap=costmap_of(grid, [(8.1, 7.2)]))
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == "1 people within 1.5 m: (8.1, 7.2)"


def test_someone_beside_or_behind_counts_too_the_costmap_does_not_say_which_way_they_face(
) -> None:
    grid = open_room()
    for person in [(7.0, 8.2), (5.9, 7.0)]:
        condition = check(robot_pose=ROBOT, occupancy=grid, costmap=costmap_of(grid, [person]))
        assert condition.status == Status.SUCCESS, person


def test_the_guest_in_tow_stopped_on_the_trail_behind_is_left_out() -> None:
    grid = open_room()
    trail = RfidHistory()
    for t in range(11):  # the robot came along y = 7 to (7, 7); the guest stops 1.2 m back
        trail.add(RfidReading(stamp=float(t), x=2.0 + 0.5 * t, y=7.0, names=frozenset()))
    costmap = costmap_of(grid, [(5.8, 7.0)])
    leading = check(robot_pose=ROBOT, occupancy=grid, costmap=costmap, guest_follows=True,
                    rfid_history=trail)
    assert leading.status == Status.FAILURE
    alone = check(robot_pose=ROBOT, occupancy=grid, costmap=costmap, guest_follows=False,
                  rfid_history=trail)
    assert alone.status == Status.SUCCESS


def test_people_beyond_a_lanes_length_are_not() -> None:
    grid = open_room()
    condition = check(robot_pose=ROBOT, occupancy=grid,
                      costmap=costmap_of(grid, [(9.0, 7.0), (7.0, 4.5)]))
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == "nobody within 1.5 m"


def test_walls_are_nobody() -> None:
    grid = open_room()
    against_the_wall = Pose2D(0.6, 7.0, 0.0)
    condition = check(robot_pose=against_the_wall, occupancy=grid, costmap=costmap_of(grid, []))
    assert condition.status == Status.FAILURE


def test_without_a_costmap_nobody_is_seen() -> None:
    condition = check(robot_pose=ROBOT, occupancy=open_room())
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == "no costmap: nobody seen"


def test_without_a_pose_it_fails_saying_so() -> None:
    grid = open_room()
    condition = check(occupancy=grid, costmap=costmap_of(grid, [(8.0, 7.0)]))
    assert condition.status == Status.FAILURE
    assert condition.feedback_message.startswith("cannot look for people")


def test_it_is_a_condition() -> None:
    assert kind_of(PeopleHeldUp) == "Condition"
