"""A recorded run: :class:`RecordedRun`, the errand tree of scripted :class:`Step` leaves run to
its end with a tree log, and what every tick really was."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import py_trees
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml
from py_trees.ports import BehaviourWithPorts, PortInformation

from bt_servicesim.records.drawing import tree_text
from bt_servicesim.records.tree_log import TreeLog
from bt_servicesim.tree.shape import NodeState, TreeShape, walk

Status = py_trees.common.Status

#: The errand tree: a sequence, a subtree with a fallback, a decorator, of scripted :class:`Step`
#: leaves; it runs to its end in a few ticks.
ERRAND_XML = """<root BTCPP_format="4" main_tree_to_execute="Errand">
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


def errand_tree(tmp_path: Path) -> py_trees.trees.BehaviourTree:
    tree_file = tmp_path / "errand.xml"
    tree_file.write_text(ERRAND_XML)
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
