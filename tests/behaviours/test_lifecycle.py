"""LeafLifecycle: leaves tick and stop exactly as py_trees' own ``Behaviour`` does.

The same tree is built twice, once of leaves on py_trees' ``Behaviour`` and once of leaves on
:class:`LeafLifecycle`, each leaf playing a seeded script of outcomes (an invalid status among
them) and writing down every ``initialise``, ``update`` and ``terminate``; both trees tick, are
stopped from above midway and tick again, and every call, status and iterator left behind
must be the same.
"""

from __future__ import annotations

import random
from collections.abc import Callable

import py_trees
import pytest
from py_trees.common import Status

from bt_servicesim.behaviours.lifecycle import LeafLifecycle

Calls = list[tuple[str, str, object]]
OUTCOMES = (Status.RUNNING, Status.SUCCESS, Status.FAILURE)


class Played(py_trees.behaviour.Behaviour):
    """Plays ``script`` (one outcome per update, cycling) and writes its calls to ``calls``."""

    def __init__(self, name: str, script: list[object], calls: Calls) -> None:
        super().__init__(name=name)
        self.script, self.calls, self.played = script, calls, 0

    def initialise(self) -> None:
        self.calls.append((self.name, "initialise", self.status))

    def update(self) -> Status:
        outcome = self.script[self.played % len(self.script)]
        self.played += 1
        self.calls.append((self.name, "update", outcome))
        self.feedback_message = f"played {self.played}"
        return outcome  # type: ignore[return-value]  # an invalid one, too, on purpose

    def terminate(self, new_status: Status) -> None:
        self.calls.append((self.name, "terminate", (self.status, new_status)))


class LeanPlayed(LeafLifecycle, Played):
    """The same leaf on the lean lifecycle."""


def tree(leaf: Callable[[str, list[object], Calls], Played], seed: int,
         calls: Calls) -> py_trees.behaviour.Behaviour:
    draw = random.Random(seed)

    def script() -> list[object]:
        played: list[object] = [draw.choice(OUTCOMES) for _ in range(draw.randint(1, 5))]
        if draw.random() < 0.3:
            played.append(draw.choice([None, "SUCCESS"]))  # no status: py_trees makes it INVALID
        return played

    reactive = py_trees.composites.Sequence("Reactive", memory=False, children=[
        leaf(f"check{index}", script(), calls) for index in range(3)])
    fallback = py_trees.composites.Selector("Fallback", memory=True, children=[
        leaf(f"try{index}", script(), calls) for index in range(3)])
    watched = py_trees.decorators.FailureIsRunning(
        "Watch", child=leaf("watch", script(), calls))
    both = py_trees.composites.Parallel(
        "Both", policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
        children=[watched, fallback])
    return py_trees.composites.Sequence("Root", memory=True, children=[reactive, both])


def played(leaf: Callable[[str, list[object], Calls], Played], seed: int) -> list[object]:
    calls: Calls = []
    root = tree(leaf, seed, calls)
    seen: list[object] = []
    iterators = {node.name: node.iterator for node in root.iterate()}
    for tick in range(40):
        if tick == 20:
            root.stop(Status.INVALID)  # stopped from above, as an interrupted run is
        root.tick_once()
        seen.append([(node.name, node.status, node.feedback_message,
                      node.iterator is not iterators[node.name]) for node in root.iterate()])
        iterators = {node.name: node.iterator for node in root.iterate()}
    return [calls, seen]


@pytest.mark.parametrize("seed", range(12))
def test_leaves_tick_and_stop_as_py_trees_leaves_do(seed: int) -> None:
    assert played(LeanPlayed, seed) == played(Played, seed)


def test_while_py_trees_logs_debug_its_own_methods_run(monkeypatch: pytest.MonkeyPatch) -> None:
    lines: list[str] = []
    monkeypatch.setattr(py_trees.logging, "level", py_trees.logging.Level.DEBUG)
    monkeypatch.setattr(py_trees.console, "logdebug", lines.append)
    written = {}
    for leaf in (Played, LeanPlayed):
        lines.clear()
        leaf("leaf", [Status.SUCCESS], []).tick_once()
        written[leaf] = [line.replace("LeanPlayed", "Played") for line in lines]
    assert written[LeanPlayed] == written[Played]
    assert any(".stop(Status.INVALID->Status.SUCCESS)" in line for line in written[Played])
