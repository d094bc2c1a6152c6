"""A tree file that would read the wall clock, or load differently each time, is refused.

A seed replays a mission only if nothing in it reads the wall clock and every load builds the
same tree: py_trees' ``Timeout`` and ``Timer`` run on the wall clock, and py_trees names an
unnamed ``<SubTree>`` (or leaf) with a random uuid, from which JitterGoal would seed itself.
"""

from __future__ import annotations

import inspect
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import py_trees
import pytest
from py_trees.parsers.behaviour_tree_xml import DECORATOR_NODES

from bt_servicesim.behaviours.actions.goals import JitterGoal
from bt_servicesim.tree.files import DEFAULT_TREE, TREES_DIRECTORY
from bt_servicesim.tree.loading import MissionTreeError, load_mission_tree
from bt_servicesim.tree.validation import WALL_CLOCK_NODES

SUBTREE = '<BehaviorTree ID="Wait"><SimWait name="Pause" seconds="1.0"/></BehaviorTree>'


def tree_file(directory: Path, body: str, *, extra: str = "") -> Path:
    path = directory / "tree.xml"
    path.write_text(f'<root BTCPP_format="4" main_tree_to_execute="M">'
                    f'<BehaviorTree ID="M">{body}</BehaviorTree>{extra}</root>')
    return path


@pytest.mark.parametrize(("body", "named", "instead"), [
    pytest.param('<Timeout name="Limit" duration="5.0"><SimWait name="W" seconds="1.0"/>'
                 "</Timeout>", '<Timeout name="Limit">', "use SimTimeout", id="Timeout"),
    pytest.param('<timeout name="Limit" duration="5.0"><SimWait name="W" seconds="1.0"/>'
                 "</timeout>", '<timeout name="Limit">', "use SimTimeout",
                 id="timeout"),  # py_trees matches decorators in any case
    pytest.param('<Timer name="Pause" duration="2.0"/>', '<Timer name="Pause">', "use SimWait",
                 id="Timer"),
])
def test_py_trees_wall_clock_nodes_are_refused_with_the_sim_time_node_to_use(
        tmp_path: Path, body: str, named: str, instead: str) -> None:
    path = tree_file(tmp_path, body)
    with pytest.raises(MissionTreeError) as refused:
        load_mission_tree(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: {named}: ") and "wall clock" in message
    assert instead in message and "\n" not in message


def test_every_py_trees_node_the_parser_builds_that_reads_the_wall_clock_is_refused() -> None:
    """Should a py_trees upgrade add a decorator on the wall clock, this says so."""
    on_the_wall_clock = {cls.__name__ for cls in DECORATOR_NODES.values()
                         if re.search(r"\btime\.(time|monotonic|perf_counter)\(",
                                      inspect.getsource(cls))}
    assert on_the_wall_clock == {"Timeout"}
    assert on_the_wall_clock | {py_trees.timers.Timer.__name__} == set(WALL_CLOCK_NODES)


def test_a_subtree_without_a_name_is_refused(tmp_path: Path) -> None:
    path = tree_file(tmp_path, '<SubTree ID="Wait"/>', extra=SUBTREE)
    with pytest.raises(MissionTreeError) as refused:
        load_mission_tree(path)
    message = str(refused.value)
    assert message.startswith(f'{path}: <SubTree ID="Wait">: a SubTree needs a name')
    assert "uuid" in message and "\n" not in message


def test_a_named_subtree_loads(tmp_path: Path) -> None:
    root = load_mission_tree(tree_file(tmp_path, '<SubTree ID="Wait" name="Rest"/>',
                                       extra=SUBTREE))
    assert root.name == "Rest.Pause"


JITTER = '<JitterGoal {named}goal="{{goal}}" occupancy="{{occupancy}}" jittered="{{out}}"/>'


def test_a_jitter_goal_without_a_name_or_a_seed_is_refused(tmp_path: Path) -> None:
    path = tree_file(tmp_path, JITTER.format(named=""))
    with pytest.raises(MissionTreeError, match=r'<JitterGoal goal="\{goal\}".*'
                                               r"needs a name or a seed"):
        load_mission_tree(path)
    seeded = load_mission_tree(tree_file(tmp_path, JITTER.format(named='seed="7" ')))
    assert isinstance(seeded, JitterGoal) and seeded.seed == 7


def jitter_seeds(path: Path) -> list[tuple[str, int]]:
    return [(node.name, node.seed) for node in load_mission_tree(path).iterate()
            if isinstance(node, JitterGoal)]


def test_the_shipped_tree_seeds_its_jitter_goals_alike_on_every_load() -> None:
    first = jitter_seeds(DEFAULT_TREE)
    # one per NavigateWithRecovery: pick-up, drop-off (clear of people, and beside them), return
    assert len(first) == 4
    assert jitter_seeds(DEFAULT_TREE) == first


def test_every_mission_tree_shipped_passes_the_checks() -> None:
    missions = [path for path in sorted(TREES_DIRECTORY.glob("*.xml"))
                if ElementTree.parse(path).getroot().find("BehaviorTree") is not None]
    assert DEFAULT_TREE in missions
    for path in missions:
        load_mission_tree(path)


def test_a_file_of_one_tree_needs_no_main_tree_to_execute(tmp_path: Path) -> None:
    """As BehaviorTree.CPP: the only tree of a file is its main tree."""
    path = tmp_path / "tree.xml"
    path.write_text('<root BTCPP_format="4"><BehaviorTree ID="M">'
                    '<SimWait name="Pause" seconds="1.0"/></BehaviorTree></root>')
    assert load_mission_tree(path).name == "Pause"


def test_repeat_for_ever_is_the_one_negative_number_a_tree_file_takes(tmp_path: Path) -> None:
    body = '<Repeat name="Again" num_success="{n}"><SimWait name="W" seconds="1.0"/></Repeat>'
    again = load_mission_tree(tree_file(tmp_path, body.format(n=-1)))
    assert isinstance(again, py_trees.decorators.Repeat) and again.num_success == -1
    with pytest.raises(MissionTreeError, match=r'num_success="-2" is less than -1'):
        load_mission_tree(tree_file(tmp_path, body.format(n=-2)))
