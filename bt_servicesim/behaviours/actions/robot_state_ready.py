"""Wait until the robot's own picture of the world is on the blackboard.

The topic readers run beside the mission and fill ``robot_pose`` and ``occupancy`` as soon as
odometry and the map arrive. Goal computation needs both, so the mission waits for them once,
in ``BeginTask``, with a behaviour that stays RUNNING rather than one that fails: a late topic is
a normal start-up, not an error worth a retry.
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ActionNode
from bt_servicesim.planning.geometry import Pose2D


class RobotStateReady(ActionNode):
    """RUNNING until the robot pose and the occupancy grid are both available, then SUCCESS."""

    INPUT_PORTS = {
        "robot_pose": PortInformation(data_type=Pose2D, description="from odometry"),
        "occupancy": PortInformation(data_type=object, description="from the map"),
    }
    OUTPUT_PORTS: dict[str, PortInformation] = {}

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)

    def update(self) -> py_trees.common.Status:
        missing = [port for port in self.INPUT_PORTS if not self._available(port)]
        if missing:
            self.feedback_message = f"waiting for {' and '.join(missing)}"
            return py_trees.common.Status.RUNNING
        self.feedback_message = "robot pose and map available"
        return py_trees.common.Status.SUCCESS

    def _available(self, port: str) -> bool:
        try:
            self.get_input(port)
        except NoDataAvailable:
            return False
        return True


