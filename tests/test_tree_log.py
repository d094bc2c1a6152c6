"""The snapshot log: what a run writes tick by tick, and what reading it back reconstructs.

A small XML tree (a sequence, a subtree with a fallback, a decorator) of scripted leaves runs to
its end with the log attached as a post-tick handler; the live tree's statuses are captured at
every tick and compared with what the log says about that tick.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import py_trees
import pytest
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from py_trees.ports import BehaviourWithPorts, PortInformation

from bt_servicesim.records.drawing import tree_text
from bt_servicesim.records.tree_log import TreeLog, TreeLogError, read_tree_log
from bt_servicesim.tree.shape import NodeState, ShadowTree, TreeShape, walk

Status = py_trees.common.Status

TREE_XML = """<root BTCPP_format="4" main_tree_to_execute="Errand">
  <BehaviorTree ID="Errand">
    <Sequence name="Errand" memory="true">
      <Step name="Approach" outcomes="RUNNING RUNNING SUCCESS" progress="{progress}"/>
      <SubTree ID="Deliver" name="Deliver" progress="{progress}"/>
      <Inverter name="NotDoneYet"><Step name="Check" outcomes="FAILURE"/></Inverter>
      <Step name="Linger" outcomes="RUNNING RUNNING RUNNING SUCCESS"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Deliver">
    <Fallback name="Deliver" memory="true">
      <Step name="Direct" outcomes="RUNNING FAILURE" progress="{progress}"/>
      <Step name="Detour" outcomes="RUNNING RUNNING SUCCESS" progress="{progress}"/>
    </Fallback>
  </BehaviorTree>
</root>
"""


class Step(BehaviourWithPorts, register=False):
    """Plays a list of outcomes, one per tick; writes its progress to the blackboard."""

    INPUT_PORTS: ClassVar[dict[str, PortInformation]] = {}
    OUTPUT_PORTS: ClassVar[dict[str, PortInformation]] = {
        "progress": PortInformation(data_type=str, required=False)}

    def __init__(self, name: str, outcomes: str = "SUCCESS", **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.outcomes = [Status[word] for word in outcomes.split()]
        self.played = 0

    def initialise(self) -> None:
        self.played = 0

    def update(self) -> Status:
        outcome = self.outcomes[min(self.played, len(self.outcomes) - 1)]
        self.played += 1
        self.feedback_message = f"step {self.played} of {len(self.outcomes)}"
        self._set_output("progress", f"{self.name.rsplit('.', 1)[-1]} step {self.played}")
        return outcome


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def errand_tree(tmp_path: Path) -> py_trees.trees.BehaviourTree:
    tree_file = tmp_path / "errand.xml"
    tree_file.write_text(TREE_XML)
    return py_trees.trees.BehaviourTree(
        parse_behaviour_tree_xml(str(tree_file), node_registry={"Step": Step}))


class RecordedRun:
    """The errand tree run to its end with a TreeLog, and the truth captured at every tick."""

    def __init__(self, tmp_path: Path) -> None:
        self.tree = errand_tree(tmp_path)
        self.sim_time_s = 100.0
        self.path = tmp_path / "tree_log.jsonl"
        self.log = TreeLog(tree=self.tree, path=self.path, sim_time_s=lambda: self.sim_time_s,
                           tree_file="errand.xml")
        self.tree.add_post_tick_handler(self.log)
        self.tree.add_post_tick_handler(self._capture)
        self.truth: dict[int, dict[str, NodeState]] = {}
        self.text: dict[int, str] = {}
        self.blackboard: dict[int, dict[str, Any]] = {}
        while self.tree.root.status not in (Status.SUCCESS, Status.FAILURE):
            self.tree.tick()
            self.sim_time_s += 0.1
        self.log.close()

    def _capture(self, tree: py_trees.trees.BehaviourTree) -> None:
        keys = TreeShape.of(tree.root).keys
        tick = tree.count + 1
        self.truth[tick] = {
            key: (behaviour.status, behaviour.feedback_message)
            for key, behaviour in zip(keys, walk(tree.root), strict=True)
        }
        self.text[tick] = tree_text(tree.root)
        self.blackboard[tick] = dict(py_trees.blackboard.Blackboard.storage)


def test_reading_the_log_gives_back_every_nodes_status_and_feedback_at_every_tick(
        tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    history = read_tree_log(run.path)
    assert history.tree_file == "errand.xml"
    assert history.shape == TreeShape.of(run.tree.root)
    for tick, truth in run.truth.items():
        assert history.at_tick(tick).nodes == truth, f"tick {tick}"
    assert history.states[-1].root == Status.SUCCESS


def test_the_log_holds_the_blackboard_values_as_they_changed(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    history = read_tree_log(run.path)
    for tick, values in run.blackboard.items():
        logged = history.at_tick(tick).blackboard
        assert logged == {key: repr(value) for key, value in values.items()}, f"tick {tick}"
    progress = [state.blackboard.get("/progress") for state in history.states]
    assert "'Detour step 3'" in progress


def test_a_line_is_written_only_when_something_changed(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    lines = [json.loads(line) for line in run.path.read_text().splitlines()]
    assert lines[0]["kind"] == "tree"
    ticks = lines[1:]
    assert len(ticks) == run.log.records
    assert ticks[0]["tick"] == 1 and len(ticks[0]["nodes"]) == len(lines[0]["nodes"])
    assert all(0 < len(line["nodes"]) < len(lines[0]["nodes"]) for line in ticks[1:])
    # ticking a finished tree again changes nothing, so nothing more is written
    before = run.log.records
    run.log(run.tree)
    assert run.log.records == before


def test_sim_time_and_tip_are_logged_with_each_change(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    history = read_tree_log(run.path)
    first = history.at_tick(1)
    assert first.sim_time_s == pytest.approx(100.0)
    assert first.tip == "Errand.Approach"
    assert history.at_time(100.25).tick == 3
    assert history.at_tick(5).tip == "Errand.Deliver.Deliver.Detour"
    assert history.at_tick(6).tip == "Errand.Linger"


def test_asking_for_a_moment_before_the_first_record_is_an_error(tmp_path: Path) -> None:
    history = read_tree_log(RecordedRun(tmp_path).path)
    with pytest.raises(TreeLogError, match="first record is tick 1"):
        history.at_tick(0)
    with pytest.raises(TreeLogError, match="first record"):
        history.at_time(3.0)


@pytest.mark.parametrize(("content", "problem"), [
    ("", "not a tree snapshot log"),
    ('{"kind": "tick"}\n', "not a tree snapshot log"),
    ('{"kind": "tree", "version": 99, "nodes": []}\n', "version 99"),
    ('{"kind": "tree", "version": 1, "nodes": [{"key": "A"}]}\n', "malformed tree shape"),
    ('{"kind": "tree", "version": 1, "nodes": [{"key": "A", "label": "A", "kind": "behaviour",'
     ' "memory": false, "parent": null}]}\nnot json\n', "line 2: not JSON"),
    ('{"kind": "tree", "version": 1, "nodes": [{"key": "A", "label": "A", "kind": "behaviour",'
     ' "memory": false, "parent": null}]}\n{"kind": "tick", "tick": 1}\n', "line 2: malformed"),
])
def test_a_broken_log_is_one_clear_error_naming_the_file(tmp_path: Path, content: str,
                                                         problem: str) -> None:
    path = tmp_path / "tree_log.jsonl"
    path.write_text(content)
    with pytest.raises(TreeLogError, match=problem) as raised:
        read_tree_log(path)
    assert str(path) in str(raised.value) and "\n" not in str(raised.value)


def test_the_latest_state_survives_an_interrupt(tmp_path: Path) -> None:
    """After Ctrl-C the live tree is stopped (all INVALID); the log still knows the last tick."""
    tree = errand_tree(tmp_path)
    log = TreeLog(tree=tree, path=tmp_path / "tree_log.jsonl", sim_time_s=lambda: 7.0)
    tree.add_post_tick_handler(log)
    for _ in range(4):
        tree.tick()
    drawn = tree_text(tree.root)
    tree.root.stop(Status.INVALID)  # what stopping a running tree does to it
    assert all(behaviour.status == Status.INVALID for behaviour in walk(tree.root))
    nodes, tip = log.latest
    shadow = ShadowTree(log.shape)
    shadow.show(nodes, tip=tip)
    assert shadow.text() == drawn
    assert tip == "Errand.Deliver.Deliver.Detour"
    log.close()
