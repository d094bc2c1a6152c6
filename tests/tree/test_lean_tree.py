"""The lean tree ticks exactly like py_trees' own: statuses, handlers, visitors, count."""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from bt_servicesim.tree.lean_tree import LeanBehaviourTree


def mission_like_tree() -> py_trees.behaviour.Behaviour:
    """A sequence that runs for two ticks, a fallback and a parallel: nodes of every kind."""
    counting = py_trees.behaviours.StatusQueue(
        name="Counting", queue=[Status.RUNNING, Status.RUNNING], eventually=Status.SUCCESS)
    fallback = py_trees.composites.Selector(name="Fallback", memory=False, children=[
        py_trees.behaviours.Failure(name="Fails"), py_trees.behaviours.Success(name="Succeeds")])
    sequence = py_trees.composites.Sequence(name="Sequence", memory=True,
                                            children=[counting, fallback])
    return py_trees.composites.Parallel(
        name="Root", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[sequence, py_trees.decorators.FailureIsRunning(
            name="KeepsRunning", child=py_trees.behaviours.Failure(name="Inner"))])


class Recorder(py_trees.visitors.VisitorBase):
    def __init__(self, *, full: bool) -> None:
        super().__init__(full=full)
        self.seen: list[list[str]] = []

    def initialise(self) -> None:
        self.seen.append([])

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        self.seen[-1].append(f"{behaviour.name}:{behaviour.status.name}")


def history(tree: py_trees.trees.BehaviourTree, ticks: int) -> tuple[list[list[str]], ...]:
    """Every node's status after each tick, what the visitors saw, the handlers' calls."""
    partial, full = Recorder(full=False), Recorder(full=True)
    tree.add_visitor(partial)
    calls: list[str] = []
    tree.add_pre_tick_handler(lambda t: calls.append(f"pre {t.count}"))
    tree.add_post_tick_handler(lambda t: calls.append(f"post {t.count}"))
    statuses = []
    for tick in range(ticks):
        if tick == ticks - 1:
            tree.add_visitor(full)  # a full visitor: the whole-tree walk comes back
        tree.tick()
        statuses.append([f"{node.name}:{node.status.name}" for node in tree.root.iterate()])
    return statuses, partial.seen, full.seen, [calls], [[str(tree.count)]]


def test_the_lean_tree_ticks_like_py_trees() -> None:
    expected = history(py_trees.trees.BehaviourTree(mission_like_tree()), ticks=4)
    assert history(LeanBehaviourTree(mission_like_tree()), ticks=4) == expected
    statuses, partial, full, _, _ = expected
    assert "Root:RUNNING" in statuses[0] and "Counting:RUNNING" in statuses[0]
    assert "Root:SUCCESS" in statuses[2]
    assert partial[0] and full[-1]  # both kinds of visitor saw nodes
