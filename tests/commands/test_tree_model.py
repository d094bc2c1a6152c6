"""The Groot2 node model: generated from the code into trees/servicesim_nodes.xml, kept in step.

``python -m bt_servicesim.tree_model`` writes the model file, ``--check`` says whether the
committed one is stale; the model declares every node this project registers and every other
tag the trees use, each with the kind its class gives it.
"""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from bt_servicesim import tree_model
from bt_servicesim.tree.loading import DEFAULT_TREE
from bt_servicesim.tree.model import BTCPP_BUILTINS, DEFAULT_NODES, nodes_file

COMMAND = [sys.executable, "-m", "bt_servicesim.tree_model"]
TREES = [DEFAULT_TREE]


def declared(text: str) -> dict[str, ElementTree.Element]:
    """The model's declarations by ID; each element's tag is the node's kind."""
    model = ElementTree.fromstring(text).find("TreeNodesModel")
    assert model is not None
    return {element.get("ID", ""): element for element in model}


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    try:
        code = tree_model.main(list(argv))
    except SystemExit as exit_:  # argparse's own errors
        code = int(exit_.code or 0)
    return code, capsys.readouterr().err


def test_the_committed_node_model_is_up_to_date() -> None:
    result = subprocess.run([*COMMAND, "--check"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert DEFAULT_NODES.parent == DEFAULT_TREE.parent


def test_each_node_is_declared_with_the_kind_its_class_gives_it() -> None:
    nodes = declared(nodes_file(TREES))
    kinds = {tag: nodes[tag].tag for tag in (
        "RecoveryNode", "GuestInRange", "RobotInArea", "RobotStateReady", "NavigateToPose",
        "SimTimeout", "Retry", "SuccessIsFailure")}
    assert kinds == {
        "RecoveryNode": "Control", "GuestInRange": "Condition", "RobotInArea": "Condition",
        "RobotStateReady": "Action", "NavigateToPose": "Action", "SimTimeout": "Decorator",
        "Retry": "Decorator", "SuccessIsFailure": "Decorator"}


def test_ports_and_constructor_settings_are_declared_with_their_types_and_defaults() -> None:
    nodes = declared(nodes_file(TREES))

    def ports(tag: str) -> dict[str, dict[str, str]]:
        return {port.get("name", ""): {"direction": port.tag, **port.attrib}
                for port in nodes[tag]}

    retries = ports("RecoveryNode")["number_of_retries"]
    assert retries == {"direction": "input_port", "name": "number_of_retries", "type": "int",
                       "default": "1"}
    assert ports("Retry") == {"num_failures": {"direction": "input_port",
                                               "name": "num_failures", "type": "int"}}
    assert ports("ExplorationWaypoints")["waypoints"]["direction"] == "output_port"
    assert ports("ExplorationWaypoints")["waypoints"]["type"] == "list[Pose2D]"
    assert ports("SimTimeout")["seconds"]["default"] == "10.0"  # the constructor's
    assert ports("RobotInArea")["margin"] == {"direction": "input_port", "name": "margin",
                                              "type": "float", "default": "0.15"}
    assert list(nodes["FailureIsRunning"]) == []


def test_every_tag_the_tree_uses_and_every_registered_node_is_declared() -> None:
    tree = ElementTree.parse(DEFAULT_TREE).getroot()
    used = {element.tag for behaviour_tree in tree.findall("BehaviorTree")
            for element in behaviour_tree.iter()} - BTCPP_BUILTINS
    nodes = declared(nodes_file(TREES))
    assert used <= set(nodes)
    assert "RecoveryNode" in used and "Retry" in used
    # a tree that uses none of them still gets every node of this project
    assert {"GuestInRange", "RecoveryNode", "CopyGoal"} <= set(declared(nodes_file([])))
    assert "Retry" not in declared(nodes_file([]))
    assert not set(nodes) & BTCPP_BUILTINS


def test_the_tree_file_no_longer_carries_a_model_of_its_own() -> None:
    assert "<TreeNodesModel>" not in DEFAULT_TREE.read_text()
    assert "servicesim_nodes.xml" in DEFAULT_TREE.read_text()  # its header says where it is


def test_a_stale_or_missing_model_is_reported_then_rewritten(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "nodes.xml"
    out.write_text(DEFAULT_NODES.read_text().replace('ID="RecoveryNode"', 'ID="Gone"'))
    code, err = run(capsys, "--check", "--out", str(out))
    assert code == 1
    assert "stale" in err and str(out) in err and err.count("\n") == 1
    assert 'ID="Gone"' in out.read_text(), "--check writes nothing"
    assert run(capsys, "--out", str(out))[0] == 0
    assert out.read_text() == DEFAULT_NODES.read_text()
    assert run(capsys, "--check", "--out", str(out)) == (0, "")
    missing = tmp_path / "missing.xml"
    assert run(capsys, "--check", "--out", str(missing))[0] == 1
    assert not missing.exists()


def test_the_trees_can_be_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.xml"
    tree.write_text('<root BTCPP_format="4"><BehaviorTree ID="T"><Inverter name="I">'
                    '<GuestInRange name="G"/></Inverter></BehaviorTree></root>')
    out = tmp_path / "nodes.xml"
    assert run(capsys, "--out", str(out), str(tree)) == (0, "")
    nodes = declared(out.read_text())
    assert nodes["Inverter"].tag == "Decorator"
    assert "Retry" not in nodes  # the mission tree was not read


@pytest.mark.parametrize(("tree_text", "problem"), [
    ('<root><BehaviorTree ID="T"><Teleport name="T"/></BehaviorTree></root>',
     "unknown tag <Teleport>"),
    ("<root><BehaviorTree", "not well-formed XML"),
    (None, "No such file"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                          tree_text: str | None, problem: str) -> None:
    tree = tmp_path / "tree.xml"
    if tree_text is not None:
        tree.write_text(tree_text)
    out = tmp_path / "nodes.xml"
    for check in ([], ["--check"]):
        code, err = run(capsys, *check, "--out", str(out), str(tree))
        assert code == 2
        assert problem in err and str(tree) in err and err.count("\n") == 1
        assert not out.exists()
