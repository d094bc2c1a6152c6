"""CopyGoal: the goal copied to another key, through its ports on the blackboard."""

from __future__ import annotations

import py_trees
from py_trees.blackboard import Blackboard

from bt_servicesim.behaviours.actions.copy_goal import CopyGoal
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.planning.geometry import Pose2D
from tests.fakes.leaves import ready


def copier() -> CopyGoal:
    return ready(CopyGoal(name="copy_goal"), goal="/goal", copy="/requested_goal")


def test_the_goal_is_copied_to_the_output() -> None:
    behaviour = copier()
    Blackboard.set("/goal", Pose2D(1.0, 2.5, 0.5))
    behaviour.tick_once()
    assert behaviour.status == py_trees.common.Status.SUCCESS
    assert Blackboard.get("/requested_goal") == Pose2D(1.0, 2.5, 0.5)
    assert behaviour.feedback_message == "goal (1.00, 2.50)"
    assert kind_of(CopyGoal) == "Action"


def test_each_tick_copies_the_goal_of_that_moment() -> None:
    behaviour = copier()
    Blackboard.set("/goal", Pose2D(1.0, 2.5))
    behaviour.tick_once()
    Blackboard.set("/goal", Pose2D(-3.0, 4.0))
    behaviour.tick_once()
    assert behaviour.status == py_trees.common.Status.SUCCESS
    assert Blackboard.get("/requested_goal") == Pose2D(-3.0, 4.0)
    assert Blackboard.get("/goal") == Pose2D(-3.0, 4.0)  # the input is left as it was


def test_without_a_goal_it_fails_and_writes_nothing() -> None:
    behaviour = copier()
    behaviour.tick_once()
    assert behaviour.status == py_trees.common.Status.FAILURE
    assert behaviour.feedback_message == "no goal to copy"
    assert not Blackboard.exists("/requested_goal")
