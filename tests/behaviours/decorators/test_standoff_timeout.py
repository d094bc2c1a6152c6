"""StandoffTimeout: a navigation stopped once the robot has stood holding someone up.

Its ports on the blackboard as the mission tree wires them (the robot's pose, the map,
navigation's costmap drawn as the simulator draws people, tests/fakes/maps.py); sim time on a
manual clock the test advances.
"""

from __future__ import annotations

from typing import Any

import py_trees
import pytest
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.decorators.standoff_timeout import StandoffTimeout
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.give_way import Standstill
from bt_servicesim.planning.guest_localisation import RfidHistory, RfidReading
from tests.fakes.leaves import wire
from tests.fakes.maps import costmap_of, open_room
from tests.mission_script import ManualClock

Status = py_trees.common.Status
ROBOT = Pose2D(7.0, 7.0, 0.0)
WALKER_AHEAD = (8.1, 7.2)
TICK_S = 0.1


def watch(child: py_trees.behaviour.Behaviour | None = None, *, people: list[Any],
          **inputs: Any) -> tuple[StandoffTimeout, ManualClock]:
    clock = ManualClock()
    grid = open_room()
    decorator = StandoffTimeout(name="standoff",
                                child=child or py_trees.behaviours.Running(name="navigate"))
    wire(decorator, clock, robot_pose=ROBOT, occupancy=grid, costmap=costmap_of(grid, people),
         **inputs)
    return decorator, clock


def arrive(decorator: StandoffTimeout, clock: ManualClock) -> None:
    """The robot comes 1 m along y = 7 to ROBOT, at 0.5 m/s, and stops there."""
    for step in range(20):
        Blackboard.set("/robot_pose", Pose2D(ROBOT.x - 1.0 + 0.05 * step, ROBOT.y, 0.0))
        decorator.tick_once()
        clock.advance(TICK_S)
    Blackboard.set("/robot_pose", ROBOT)


def tick_for(decorator: StandoffTimeout, clock: ManualClock, seconds: float) -> list[Status]:
    statuses = []
    for _ in range(round(seconds / TICK_S)):
        decorator.tick_once()
        statuses.append(decorator.status)
        clock.advance(TICK_S)
    return statuses


def test_standing_four_seconds_before_a_walker_stops_the_navigation() -> None:
    decorator, clock = watch(people=[WALKER_AHEAD])
    arrive(decorator, clock)
    statuses = tick_for(decorator, clock, 4.1)
    assert statuses[:40] == [Status.RUNNING] * 40
    assert statuses[40] == Status.FAILURE
    assert decorator.decorated.status == Status.INVALID  # the goal is cancelled
    assert decorator.feedback_message == "stood 4.0 sim s: 1 people within 1.5 m: (8.1, 7.2)"


def test_a_robot_on_the_move_is_left_to_its_navigation() -> None:
    decorator, clock = watch(people=[WALKER_AHEAD])
    for step in range(100):  # 10 sim s at 0.3 m/s, someone near all along
        Blackboard.set("/robot_pose", Pose2D(ROBOT.x - 0.03 * step, ROBOT.y, 0.0))
        decorator.tick_once()
        clock.advance(TICK_S)
        assert decorator.status == Status.RUNNING


def test_standing_with_nobody_near_is_left_to_its_navigation() -> None:
    decorator, clock = watch(people=[(11.0, 7.0)])
    arrive(decorator, clock)
    assert set(tick_for(decorator, clock, 10.0)) == {Status.RUNNING}
    assert decorator.feedback_message == "stood 9.9 sim s: nobody within 1.5 m"


def test_a_robot_turning_to_set_off_beside_someone_is_left_to_its_navigation() -> None:
    # the robot that dropped its guest off turns on the spot and leaves beside them
    decorator, clock = watch(people=[WALKER_AHEAD])
    for step in range(60):  # 6 sim s turning at 0.5 rad/s where it started
        Blackboard.set("/robot_pose", Pose2D(ROBOT.x, ROBOT.y, 0.05 * step))
        decorator.tick_once()
        clock.advance(TICK_S)
        assert decorator.status == Status.RUNNING
    arrive(decorator, clock)
    assert Status.FAILURE in tick_for(decorator, clock, 4.1)


def test_a_robot_that_gets_nowhere_from_the_start_beside_someone_stops_after_4_s() -> None:
    # someone stands where it must go: navigation waits, neither moving nor turning the robot
    decorator, clock = watch(people=[WALKER_AHEAD])
    statuses = tick_for(decorator, clock, 4.1)
    assert statuses[:40] == [Status.RUNNING] * 40
    assert statuses[40] == Status.FAILURE


def test_the_guest_in_tow_stopped_behind_the_robot_is_nobody_held_up() -> None:
    guest = (5.8, 7.0)
    trail = RfidHistory()
    for t in range(11):  # the robot came along y = 7 to (7, 7)
        trail.add(RfidReading(stamp=float(t), x=2.0 + 0.5 * t, y=7.0, names=frozenset()))
    decorator, clock = watch(people=[guest], guest_follows=True, rfid_history=trail)
    arrive(decorator, clock)
    assert set(tick_for(decorator, clock, 6.0)) == {Status.RUNNING}
    alone, clock = watch(people=[guest], guest_follows=False)
    arrive(alone, clock)
    assert Status.FAILURE in tick_for(alone, clock, 6.0)  # without a guest in tow: someone


def test_a_finished_navigation_passes_through() -> None:
    for child, expected in ((py_trees.behaviours.Success(name="ok"), Status.SUCCESS),
                            (py_trees.behaviours.Failure(name="no"), Status.FAILURE)):
        decorator, clock = watch(child, people=[WALKER_AHEAD])
        assert tick_for(decorator, clock, 0.1) == [expected]


def test_standing_counts_afresh_for_each_goal() -> None:
    decorator, clock = watch(people=[WALKER_AHEAD])
    arrive(decorator, clock)
    tick_for(decorator, clock, 3.0)
    decorator.stop(Status.INVALID)  # the goal ended; the next begins where the robot stands
    arrive(decorator, clock)
    assert tick_for(decorator, clock, 3.5)[-1] == Status.RUNNING


def test_without_a_costmap_it_only_passes_through() -> None:
    decorator, clock = watch(people=[])
    arrive(decorator, clock)
    Blackboard.unset("/costmap")
    assert set(tick_for(decorator, clock, 6.0)) == {Status.RUNNING}
    assert decorator.feedback_message.endswith("no costmap: nobody seen")


def test_it_is_a_decorator() -> None:
    assert kind_of(StandoffTimeout) == "Decorator"


@pytest.mark.parametrize(("moves", "stood"), [
    ([(0.0, 0.0, 0.0, 0.0), (0.1, 0.0, 0.0, 2.0), (0.1, 0.1, 0.0, 5.0)], 5.0),  # never got going
    ([(0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 2.0), (0.0, 0.0, 1.1, 5.0)], 3.0),  # turned to set off
    ([(0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 2.0), (0.0, 0.0, 2.0, 5.0)], 0.0),  # still turning
    ([(0.0, 0.0, 0.0, 0.0), (0.3, 0.0, 0.0, 2.0), (0.3, 0.0, 0.0, 5.0)], 3.0),  # stopped at 2 s
    ([(0.0, 0.0, 0.0, 0.0), (0.3, 0.0, 0.0, 2.0), (0.4, 0.1, 0.0, 5.0)], 3.0),  # jitter, 0.15 m
    ([(0.0, 0.0, 0.0, 0.0), (0.3, 0.0, 0.0, 2.0), (0.3, 0.0, 1.5, 5.0)], 3.0),  # turns on its way
    ([(0.0, 0.0, 0.0, 0.0), (0.3, 0.0, 0.0, 2.0), (0.6, 0.0, 0.0, 5.0)], 0.0),  # on the move
    ([(0.0, 0.0, 3.1, 0.0), (0.0, 0.0, -3.1, 5.0)], 5.0),  # 0.08 rad across the wrap: no turn
])
def test_standstill_counts_from_where_the_robot_last_stopped_or_got_nowhere(
        moves: list[tuple[float, float, float, float]], stood: float) -> None:
    standstill = Standstill()
    results = [standstill.stood(x, y, yaw, now) for x, y, yaw, now in moves]
    assert results[-1] == pytest.approx(stood)
