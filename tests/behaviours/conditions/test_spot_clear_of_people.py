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
