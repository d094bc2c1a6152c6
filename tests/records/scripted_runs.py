"""Scripted missions with a snapshot log, for profile and node-table tests without a ROS graph.

The real tree file is parsed with scripted leaves (tests/mission_script.py), ticked on a manual
clock every 0.1 sim s, and logged by the real :class:`TreeLog`; a test gives the referee's
bookings as a function of the state of the tree at each tick.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import py_trees
from py_trees.blackboard import Blackboard
from py_trees.parsers.behaviour_tree_xml import parse_behaviour_tree_xml

from bt_servicesim.records.profile import Booking, build_profile
from bt_servicesim.records.tree_log import TreeLog, read_records
from bt_servicesim.tree.loading import DEFAULT_TREE
from tests.mission_script import ManualClock, Script, scripted_registry

Status = py_trees.common.Status
TICK_S = 0.1

Booker = Callable[[py_trees.behaviour.Behaviour, float], dict[str, float]]
"""The points booked from one tick to the next, by cause, given the tip and the tick's sim time."""


@dataclass
class ScriptedRun:
    """A scripted mission played to its end with a snapshot log and the bookings made."""

    log: Path
    bookings: list[Booking] = field(default_factory=list)

    def profile(self) -> dict:
        header, records = read_records(self.log)
        return build_profile(shape=header.shape, records=records, phases=header.phases,
                             bookings=self.bookings, tree_file=header.tree_file,
                             counts=header.counts)


def play(directory: Path, script: Script, *, tree_file: Path = DEFAULT_TREE,
         book: Booker | None = None, max_ticks: int = 5000) -> ScriptedRun:
    Blackboard.clear()
    directory.mkdir(parents=True, exist_ok=True)
    root = parse_behaviour_tree_xml(str(tree_file),
                                    node_registry=scripted_registry(tree_file, script),
                                    input_mappings={"time_limit": "900.0"})
    tree = py_trees.trees.BehaviourTree(root)
    clock = ManualClock()
    tree.setup(node=clock)

    def sim_time_s() -> float:
        return clock.nanoseconds / 1e9

    log = TreeLog(tree=tree, path=directory / "tree_log.jsonl", sim_time_s=sim_time_s,
                  tree_file=tree_file.name, phases="Mission")
    tree.add_post_tick_handler(log)
    run = ScriptedRun(log=log.path)
    sums: dict[str, float] = {}
    for _ in range(max_ticks):
        tree.tick()
        booked = {} if book is None else book(root.tip(), sim_time_s())
        clock.advance(TICK_S)  # the points are booked while the world steps to the next tick
        for cause, points in booked.items():
            sums[cause] = sums.get(cause, 0.0) + points
        run.bookings.append(Booking(sim_time_s=sim_time_s(), sums=dict(sums)))
        if root.status in (Status.SUCCESS, Status.FAILURE):
            break
    log.close()
    return run
