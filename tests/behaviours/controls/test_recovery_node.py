"""RecoveryNode: Nav2's semantics, branch by branch, on py_trees' own test behaviours.

Each tick's trace is what the node yields: every behaviour ticked below it, in order, then the
node itself; so a trace shows whether the recovery ran and whether the action ran again in the
same tick. The last tests build the node from a tree file, as the mission does.
"""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest
from py_trees.behaviours import Failure, Running, StatusQueue, Success

from bt_servicesim.behaviours import node_registry
from bt_servicesim.behaviours.controls.recovery_node import RecoveryNode
from bt_servicesim.behaviours.node import kind_of
from bt_servicesim.tree.loading import MissionTreeError, load_mission_tree

Status = py_trees.common.Status
S, F, R = Status.SUCCESS, Status.FAILURE, Status.RUNNING


class Recorded(StatusQueue):
    """py_trees' StatusQueue that also notes its lifecycle calls."""

    def __init__(self, name: str, queue: list[Status], eventually: Status | None) -> None:
        super().__init__(name=name, queue=queue, eventually=eventually)
        self.events: list[str] = []

    def initialise(self) -> None:
        self.events.append("initialise")

    def terminate(self, new_status: Status) -> None:
        self.events.append(new_status.name)


def tick(node: py_trees.behaviour.Behaviour) -> list[str]:
    """One tick; the names of the behaviours it ticked, the node last."""
    return [behaviour.name for behaviour in node.tick()]


def recovery_node(action_queue: list[Status], recovery_queue: list[Status], *,
                  retries: int | None = None,
                  eventually: tuple[Status, Status] = (F, S)) -> RecoveryNode:
    action = Recorded("action", action_queue, eventually[0])
    recovery = Recorded("recovery", recovery_queue, eventually[1])
    if retries is None:
        return RecoveryNode(name="node", children=[action, recovery])
    return RecoveryNode(name="node", children=[action, recovery], number_of_retries=retries)


def test_an_action_that_succeeds_is_success_and_the_recovery_never_runs() -> None:
    node = RecoveryNode(name="node", children=[Success("action"), Failure("recovery")])
    assert tick(node) == ["action", "node"]
    assert node.status == S
    assert node.children[1].status == Status.INVALID
    assert node.tip() is node.children[0]


def test_a_running_action_is_running_and_points_the_tip_at_it() -> None:
    node = RecoveryNode(name="node", children=[Running("action"), Failure("recovery")])
    for _ in range(3):
        assert tick(node) == ["action", "node"]
        assert node.status == R
        assert node.tip() is node.children[0]


def test_a_failed_action_is_recovered_then_run_again_in_the_same_tick() -> None:
    node = recovery_node([F, S], [S], retries=3)
    assert tick(node) == ["action", "recovery", "action", "node"]
    assert node.status == S
    assert node.retries == 1


def test_the_action_runs_again_afresh_and_the_recovery_is_halted() -> None:
    node = recovery_node([F, S], [S], retries=1)
    action, recovery = node.children
    tick(node)
    assert action.events == ["initialise", "FAILURE", "INVALID", "initialise", "SUCCESS"]
    assert recovery.events == ["initialise", "SUCCESS", "INVALID"]
    assert recovery.status == Status.INVALID


def test_a_running_recovery_is_running_then_the_action_runs_again_once_it_succeeds() -> None:
    node = recovery_node([F, R], [R, R, S], retries=1)
    assert tick(node) == ["action", "recovery", "node"]
    assert node.status == R and node.tip() is node.children[1]
    assert tick(node) == ["recovery", "node"]
    assert node.status == R
    assert tick(node) == ["recovery", "action", "node"]
    assert node.status == R and node.tip() is node.children[0]
    assert node.retries == 1


def test_a_failed_recovery_fails_the_node_without_another_attempt() -> None:
    node = recovery_node([F], [F], retries=5)
    assert tick(node) == ["action", "recovery", "node"]
    assert node.status == F
    assert node.retries == 0
    assert node.tip() is node.children[1]


def test_once_the_retries_are_spent_the_action_fails_the_node_and_no_recovery_runs() -> None:
    node = recovery_node([], [], retries=2)  # the action always fails, the recovery always works
    assert tick(node) == ["action", "recovery", "action", "recovery", "action", "node"]
    assert node.status == F
    assert node.retries == 2
    assert node.children[1].events == ["initialise", "SUCCESS", "INVALID"] * 2


def test_no_retries_means_one_attempt_and_no_recovery() -> None:
    node = recovery_node([], [], retries=0)
    assert tick(node) == ["action", "node"]
    assert node.status == F
    assert node.children[1].events == []


def test_one_retry_by_default() -> None:
    node = recovery_node([], [])
    assert tick(node) == ["action", "recovery", "action", "node"]
    assert node.status == F


def test_the_retries_are_counted_afresh_each_time_the_node_starts() -> None:
    node = recovery_node([F, F, F, F, S], [S, S], retries=1)
    for _ in range(2):  # had the count not started over, the second run would not recover
        assert tick(node) == ["action", "recovery", "action", "node"]
        assert node.status == F and node.retries == 1
    assert tick(node) == ["action", "node"]
    assert node.status == S and node.retries == 0


def test_stopping_the_node_stops_the_running_action() -> None:
    node = recovery_node([R], [S], retries=1, eventually=(R, S))
    tick(node)
    node.stop(Status.INVALID)
    action = node.children[0]
    assert action.status == Status.INVALID and action.events[-1] == "INVALID"
    assert node.status == Status.INVALID
    assert node.tip() is None


def test_stopping_the_node_stops_the_running_recovery_and_it_starts_over_after() -> None:
    node = recovery_node([F, F, S], [R], retries=1, eventually=(F, R))
    tick(node)
    recovery = node.children[1]
    assert recovery.status == R
    node.stop(Status.INVALID)
    assert recovery.status == Status.INVALID and recovery.events[-1] == "INVALID"
    assert tick(node) == ["action", "recovery", "node"]  # the action first again
    assert node.retries == 0


@pytest.mark.parametrize("count", [1, 3])
def test_the_node_needs_exactly_two_children(count: int) -> None:
    with pytest.raises(ValueError, match="exactly 2 children"):
        RecoveryNode(name="node", children=[Success(f"child{i}") for i in range(count)])
    node = RecoveryNode(name="node")
    for i in range(count):
        node.add_child(Success(f"child{i}"))
    with pytest.raises(ValueError, match="exactly 2 children"):
        tick(node)


def test_it_is_registered_as_a_control() -> None:
    assert node_registry()["RecoveryNode"] is RecoveryNode
    assert kind_of(RecoveryNode) == "Control"


# ------------------------------------------------------------------------------ from a tree file
TREE = """<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <RecoveryNode name="TryToMeet" {retries}>
      <GuestInRange name="Meet" guest_name="ann" actors_in_range="{{actors}}"/>
      <Inverter name="NobodyThere">
        <GuestInRange name="Look" guest_name="ann" actors_in_range="{{actors}}"/>
      </Inverter>
    </RecoveryNode>
  </BehaviorTree>
</root>
"""


def load(tmp_path: Path, retries: str) -> py_trees.behaviour.Behaviour:
    tree_file = tmp_path / "tree.xml"
    tree_file.write_text(TREE.format(retries=retries))
    return load_mission_tree(tree_file)


def short(names: list[str]) -> list[str]:
    return [name.rsplit(".", 1)[-1] for name in names]


def test_a_tree_file_sets_the_number_of_retries(tmp_path: Path) -> None:
    root = load(tmp_path, 'number_of_retries="2"')
    assert isinstance(root, RecoveryNode)
    py_trees.blackboard.Blackboard.set("/actors", [])
    assert short(tick(root)) == ["Meet", "Look", "NobodyThere", "Meet", "Look", "NobodyThere",
                                 "Meet", "TryToMeet"]
    assert root.status == F
    py_trees.blackboard.Blackboard.set("/actors", ["ann"])
    assert short(tick(root)) == ["Meet", "TryToMeet"]
    assert root.status == S


def test_a_tree_file_that_leaves_the_number_out_gets_one_retry(tmp_path: Path) -> None:
    root = load(tmp_path, "")
    py_trees.blackboard.Blackboard.set("/actors", [])
    assert short(tick(root)) == ["Meet", "Look", "NobodyThere", "Meet", "TryToMeet"]
    assert root.status == F


def test_a_tree_file_can_wire_the_number_to_a_key(tmp_path: Path) -> None:
    root = load(tmp_path, 'number_of_retries="{retries}"')
    py_trees.blackboard.Blackboard.set("/actors", [])
    py_trees.blackboard.Blackboard.set("/retries", 0)
    assert short(tick(root)) == ["Meet", "TryToMeet"]
    assert root.status == F


def test_a_tree_file_with_a_bad_number_or_one_child_is_refused(tmp_path: Path) -> None:
    with pytest.raises(MissionTreeError, match='number_of_retries="many" is not an int'):
        load(tmp_path, 'number_of_retries="many"')
    tree_file = tmp_path / "one_child.xml"
    tree_file.write_text(TREE.format(retries="").replace(
        '<Inverter name="NobodyThere">', "").replace("</Inverter>", "").replace(
        '<GuestInRange name="Look" guest_name="ann" actors_in_range="{actors}"/>', ""))
    with pytest.raises(MissionTreeError, match="exactly 2 children"):
        load_mission_tree(tree_file)
