"""RobotInArea: is the robot's origin inside the area's box, shrunk by a margin?

Through its ports on the blackboard, as the mission tree wires it: ``box`` and ``robot_pose``.
"""

from __future__ import annotations

import py_trees
import pytest
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

from bt_servicesim.behaviours.conditions.robot_in_area import RobotInArea
from bt_servicesim.behaviours.node import ConditionNode, kind_of
from bt_servicesim.planning.geometry import Box, Pose2D
from tests.fakes.leaves import wire

Status = py_trees.common.Status
AREA = Box(-1.5, 0.0, 1.5, 2.7)


def check(pose: Pose2D | None, box: Box | None = AREA, **options: float) -> RobotInArea:
    """A RobotInArea ticked once with ``pose`` and ``box`` on the blackboard (None: missing)."""
    inputs = {key: value for key, value in (("box", box), ("robot_pose", pose))
              if value is not None}
    condition = wire(RobotInArea(name="in_area", **options), **inputs)
    condition.tick_once()
    return condition


def test_a_robot_inside_the_area_succeeds() -> None:
    condition = check(Pose2D(0.5, 1.2, 1.0))
    assert condition.status == Status.SUCCESS
    assert condition.feedback_message == "robot inside the area (0.50, 1.20)"


@pytest.mark.parametrize("pose", [Pose2D(3.0, 1.2), Pose2D(0.0, -0.5), Pose2D(-4.0, 5.0)])
def test_a_robot_outside_the_area_fails(pose: Pose2D) -> None:
    condition = check(pose)
    assert condition.status == Status.FAILURE
    assert condition.feedback_message == f"robot outside the area ({pose.x:.2f}, {pose.y:.2f})"


def test_the_margin_keeps_a_robot_near_the_edge_outside() -> None:
    near_edge = Pose2D(1.4, 1.2)  # in the box, 0.1 m from its east edge
    assert check(near_edge).status == Status.FAILURE  # the default margin is 0.15 m
    Blackboard.clear()
    assert check(near_edge, margin=0.05).status == Status.SUCCESS
    Blackboard.clear()
    assert check(Pose2D(1.3, 1.2)).status == Status.SUCCESS  # 0.2 m inside
    Blackboard.clear()
    assert check(Pose2D(0.0, 1.2), margin=1.0).status == Status.SUCCESS
    Blackboard.clear()
    assert check(Pose2D(0.0, 0.9), margin=1.0).status == Status.FAILURE  # 0.9 m from the south


def test_a_margin_of_zero_counts_the_edge_as_inside() -> None:
    assert check(Pose2D(1.5, 2.7), margin=0.0).status == Status.SUCCESS
    Blackboard.clear()
    assert check(Pose2D(1.51, 2.7), margin=0.0).status == Status.FAILURE


@pytest.mark.parametrize(("pose", "box", "missing"), [
    (None, AREA, "robot_pose"),
    (Pose2D(0.5, 1.2), None, "box"),
    (None, None, "box"),
])
def test_missing_inputs_fail(pose: Pose2D | None, box: Box | None, missing: str) -> None:
    condition = check(pose, box)
    assert condition.status == Status.FAILURE
    assert condition.feedback_message.startswith("cannot check the area")
    assert missing in condition.feedback_message


@pytest.mark.parametrize(("pose", "box"), [
    (Pose2D(0.5, 1.2), AREA), (Pose2D(1.4, 1.2), AREA), (Pose2D(9.0, 9.0), AREA),
    (None, AREA), (Pose2D(0.5, 1.2), None),
])
def test_it_is_a_condition_and_never_running(pose: Pose2D | None, box: Box | None) -> None:
    assert issubclass(RobotInArea, ConditionNode)
    assert kind_of(RobotInArea) == "Condition"
    condition = check(pose, box)
    for _ in range(3):
        assert condition.status in (Status.SUCCESS, Status.FAILURE)
        condition.tick_once()


def test_the_margin_comes_from_the_tree_file(tmp_path) -> None:
    xml_file = tmp_path / "area.xml"
    xml_file.write_text("""
<root main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <RobotInArea name="in_area" box="{box}" robot_pose="{pose}" margin="0.5"/>
  </BehaviorTree>
</root>
""")
    root = parse_behaviour_tree_xml(str(xml_file), node_registry="auto")
    assert isinstance(root, RobotInArea) and root.margin == 0.5
    Blackboard.set("/box", AREA)
    Blackboard.set("/pose", Pose2D(1.1, 1.2))  # 0.4 m inside: not enough
    root.tick_once()
    assert root.status == Status.FAILURE
    Blackboard.set("/pose", Pose2D(0.9, 1.2))
    root.tick_once()
    assert root.status == Status.SUCCESS
