"""GuestApproachGoal: a goal near where the RFID history says the guest is.

A robot drives a path on a small map, hearing the guest within RFID range as the simulator's
sensor does (``tests.fakes.guest.drive``); the goal must put it within pick-up reach of the true
guest without crowding them, on free space it can reach.
"""

from __future__ import annotations

import py_trees
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.guest_approach_goal import GuestApproachGoal
from bt_servicesim.planning.geometry import Pose2D
from bt_servicesim.planning.guest_localisation import RfidHistory
from tests.fakes.guest import GUEST, check_approach, drive
from tests.fakes.leaves import wire
from tests.fakes.maps import open_room
from tests.mission_script import ManualClock

Status = py_trees.common.Status


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
