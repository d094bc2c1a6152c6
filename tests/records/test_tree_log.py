"""The snapshot log: what a run writes tick by tick, and what reading it back reconstructs.

A small XML tree (a sequence, a subtree with a fallback, a decorator) of scripted leaves
(``tests.fakes.recorded_run.RecordedRun``) runs to its end with the log attached as a post-tick
handler; the live tree's statuses are captured at every tick and compared with what the log says
about that tick.
"""

from __future__ import annotations

import json
from pathlib import Path

import py_trees
import pytest

from bt_servicesim.records.drawing import tree_text
from bt_servicesim.records.tree_log import (
    LINES_PER_WRITE,
    TickLine,
    TickRecord,
    TreeLog,
    TreeLogError,
    TreeState,
    read_tree_log,
    stable_key,
    state_reader,
)
from bt_servicesim.tree.shape import ShadowTree, TreeShape, walk
from tests.fakes.recorded_run import RecordedRun, errand_tree

Status = py_trees.common.Status

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
        assert logged == {stable_key(key): repr(value)
                          for key, value in values.items()}, f"tick {tick}"
    assert not any("-" in key.rsplit("/", 2)[-2] for key in logged)  # no UUID in a node's key
    progress = [state.blackboard.get("/progress") for state in history.states]
    assert "'Detour step 3'" in progress


def test_a_line_is_written_only_when_something_changed(tmp_path: Path) -> None:
    run = RecordedRun(tmp_path)
    lines = [json.loads(line) for line in run.path.read_text().splitlines()]
    assert lines[0]["kind"] == "tree" and lines[-1]["kind"] == "counts"
    ticks = lines[1:-1]
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


class Token:
    """A blackboard value whose repr is its text: a new object may repr alike."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


def test_blackboard_changes_are_new_objects_with_new_reprs_and_keys_that_went(
        tmp_path: Path) -> None:
    store: dict[str, object] = {}
    log = TreeLog(tree=errand_tree(tmp_path), path=tmp_path / "tree_log.jsonl",
                  sim_time_s=lambda: 0.0, blackboard=lambda: store)
    pose = Token("at A")
    store.update({"/pose": pose, "/goal": Token("B"), "/left": Token("x")})
    assert log.capture(tick=1).blackboard == {"/pose": "at A", "/goal": "B", "/left": "x"}
    pose.text = "at C"  # changed in place: not noticed, as the module says
    store["/goal"] = Token("B")  # another object, the same repr: no change
    assert log.capture(tick=2) is None
    store["/pose"] = Token("at D")
    del store["/left"]
    store["/right"] = Token("y")  # as many keys as before, other ones
    assert log.capture(tick=3).blackboard == {"/pose": "at D", "/right": "y", "/left": None}
    del store["/right"]
    assert log.capture(tick=4).blackboard == {"/right": None}
    assert log.capture(tick=5) is None
    log.close()


def test_advancing_in_place_gives_the_state_that_applying_gives(tmp_path: Path) -> None:
    """``apply`` leaves its state as it was; ``advance`` (the tree topic's way) changes it to
    the same state a new object from ``apply`` holds."""
    run = RecordedRun(tmp_path)
    history = read_tree_log(run.path)
    lines = [json.loads(line) for line in run.path.read_text().splitlines()[1:-1]]
    latest = TreeState()
    for expected, line in zip(history.states, lines, strict=True):
        before = TreeState(tick=latest.tick, sim_time_s=latest.sim_time_s, root=latest.root,
                           tip=latest.tip, nodes=dict(latest.nodes),
                           blackboard=dict(latest.blackboard))
        record = TickRecord.from_json(line)
        applied = latest.apply(record)
        assert latest == before  # apply made a new state
        latest.advance(record)
        assert latest == applied == expected
        assert list(latest.nodes) == list(expected.nodes)  # in the same order, too
    gone = TickRecord(tick=latest.tick + 1, sim_time_s=latest.sim_time_s, root=latest.root,
                      tip=latest.tip, nodes={}, blackboard=dict.fromkeys(latest.blackboard))
    latest.advance(gone)
    assert latest.blackboard == {} and latest.tick == gone.tick


def test_the_last_line_counts_every_tick_start_and_outcome_of_every_node(
        tmp_path: Path) -> None:
    """The change lines cannot see a node that ran and finished the same way again between two
    lines; the counts line, made as the tree ticked, can."""
    run = RecordedRun(tmp_path)
    counts = json.loads(run.path.read_text().splitlines()[-1])["nodes"]
    root = run.tree.root
    assert counts[root.name][0] == run.tree.count  # the root is ticked at every tick
    for key, (ticks, starts, success, failure) in counts.items():
        assert ticks >= starts >= 1 and success + failure <= ticks, key
    assert counts[root.name][1:] == [1, 1, 0]  # started once, succeeded once



def test_each_tick_line_is_what_json_writes_of_its_record(tmp_path: Path) -> None:
    """The log writes its tick lines without building the record's dict; the text is the same
    (keys with quotes and non-ASCII, a tip that went, a blackboard key that went)."""
    run = RecordedRun(tmp_path)
    lines = run.path.read_text(encoding="utf-8").splitlines(keepends=True)[1:-1]
    assert lines and all(line == json.dumps(json.loads(line), ensure_ascii=False) + "\n"
                         for line in lines)
    odd = TickRecord(tick=7, sim_time_s=1 / 3, root=Status.FAILURE, tip=None,
                     nodes={'Main."Quoted"': (Status.RUNNING, "zwei Schritte → Ziel\n\t\\"),
                            "Main.Other": (Status.INVALID, "")},
                     blackboard={"/größe": "Pose2D(x=1.0)", "/went": None})
    assert TickLine().of(odd) == json.dumps(odd.to_json(), ensure_ascii=False) + "\n"


def test_lines_are_written_whole_in_batches_and_all_of_them_on_close(tmp_path: Path) -> None:
    tree = errand_tree(tmp_path)
    path = tmp_path / "tree_log.jsonl"
    store: dict[str, object] = {}
    log = TreeLog(tree=tree, path=path, sim_time_s=lambda: 0.0, blackboard=lambda: store)
    assert json.loads(path.read_text())["kind"] == "tree"  # the header at once
    for tick in range(1, LINES_PER_WRITE + 3):
        store["/count"] = tick  # a change every tick: a line every tick
        log.log(tick=tick)
        written = path.read_text().splitlines()
        assert len(written) == 1 + (LINES_PER_WRITE if tick >= LINES_PER_WRITE else 0), tick
    log.close()
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [line["tick"] for line in lines[1:-1]] == list(range(1, LINES_PER_WRITE + 3))
    assert lines[-1]["kind"] == "counts"


class Counting(py_trees.behaviour.Behaviour):
    """A leaf whose feedback is worked out when read (a property): not kept in its dict."""

    def __init__(self, name: str) -> None:
        self.count = 0
        super().__init__(name=name)

    @property
    def feedback_message(self) -> str:  # type: ignore[override]
        return f"ticked {self.count} times"

    @feedback_message.setter
    def feedback_message(self, _text: str) -> None:
        """py_trees sets it; the count says it."""

    def update(self) -> Status:
        self.count += 1
        return Status.RUNNING


def test_states_are_read_as_attribute_access_gives_them_from_dicts_or_not(
        tmp_path: Path) -> None:
    tree = errand_tree(tmp_path)
    reader = state_reader(walk(tree.root))
    for _ in range(4):
        tree.tick()
        assert reader() == [(node.status, node.feedback_message) for node in walk(tree.root)]
    counting = py_trees.trees.BehaviourTree(py_trees.composites.Sequence(
        "Main", memory=False, children=[Counting("Count")]))
    log = TreeLog(tree=counting, path=tmp_path / "counting.jsonl", sim_time_s=lambda: 0.0,
                  blackboard=dict)
    counting.add_post_tick_handler(log)
    for _ in range(3):
        counting.tick()
    assert log.latest[0]["Count"] == (Status.RUNNING, "ticked 3 times")
    log.close()
