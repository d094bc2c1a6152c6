"""Copy a goal to another key: the recovery ladder starts from the goal it was asked for."""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode
from bt_servicesim.planning.geometry import Pose2D


class CopyGoal(ActionNode):
    """Copy ``goal`` to ``copy``: the recovery ladder starts from the goal it was asked for."""

    INPUT_PORTS = {"goal": PortInformation(data_type=Pose2D)}
    OUTPUT_PORTS = {"copy": PortInformation(data_type=Pose2D)}

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def update(self) -> py_trees.common.Status:
        try:
            goal = self.get_input("goal")
        except NoDataAvailable:
            self.feedback_message = "no goal to copy"
            return py_trees.common.Status.FAILURE
        self._set_output("copy", goal)
        self.feedback_message = f"goal ({goal.x:.2f}, {goal.y:.2f})"
        return py_trees.common.Status.SUCCESS
