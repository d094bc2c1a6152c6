"""RobotStateReady: RUNNING until the robot pose and the map are on the blackboard."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.robot_state_ready import RobotStateReady
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.planning.geometry import Pose2D
from tests.fakes.leaves import ready
from tests.fakes.maps import open_room

Status = py_trees.common.Status


def waiting() -> RobotStateReady:
    return ready(RobotStateReady(name="ready"), robot_pose="/pose", occupancy="/occupancy")


def test_it_runs_until_both_the_pose_and_the_map_are_there() -> None:
    behaviour = waiting()
    behaviour.tick_once()
    assert behaviour.status == Status.RUNNING
    assert behaviour.feedback_message == "waiting for robot_pose and occupancy"
    Blackboard.set("/pose", Pose2D(1.0, 2.0))
    behaviour.tick_once()
    assert behaviour.status == Status.RUNNING
    assert behaviour.feedback_message == "waiting for occupancy"
    Blackboard.set("/occupancy", open_room())
    behaviour.tick_once()
    assert behaviour.status == Status.SUCCESS
    assert behaviour.feedback_message == "robot pose and map available"


@pytest.mark.parametrize(("present", "waiting_for"), [
    ((), "robot_pose and occupancy"),
    (("/pose",), "occupancy"),
    (("/occupancy",), "robot_pose"),
])
def test_a_late_topic_keeps_it_running_not_failing(present: tuple[str, ...],
                                                   waiting_for: str) -> None:
    assert kind_of(RobotStateReady) == "Action"
    inputs = {"/pose": Pose2D(1.0, 2.0), "/occupancy": open_room()}
    for key in present:
        Blackboard.set(key, inputs[key])
    behaviour = waiting()
    statuses = []
    for _ in range(5):
        behaviour.tick_once()
        statuses.append(behaviour.status)
    assert statuses == [Status.RUNNING] * 5
    assert behaviour.feedback_message == f"waiting for {waiting_for}"
