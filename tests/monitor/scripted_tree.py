"""A small scripted py_trees tree for the monitor's tests: every kind of node, fixed outcomes."""

from __future__ import annotations

import py_trees
from py_trees.common import Status


def scripted_tree() -> py_trees.trees.BehaviourTree:
    """After one tick: Root RUNNING, Check FAILURE, Work RUNNING, Later never ticked."""
    behaviours = py_trees.behaviours
    root = py_trees.composites.Sequence(name="Root", memory=True, children=[
        behaviours.Success(name="Start"),
        py_trees.composites.Selector(name="Choose", memory=False, children=[
            behaviours.Failure(name="Check"),
            py_trees.decorators.Inverter(name="Invert", child=behaviours.Failure(name="Flip")),
        ]),
        py_trees.composites.Parallel(
            name="Together", policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=[
                behaviours.StatusQueue(name="Work", queue=[Status.RUNNING] * 3,
                                       eventually=Status.SUCCESS),
                behaviours.Success(name="Beside"),
            ]),
        behaviours.Success(name="Later"),
    ])
    return py_trees.trees.BehaviourTree(root)
