"""Is the robot inside a target area? A condition on its pose and the area's box.

The referee counts checkpoints by where the robot's origin is: checkpoint 1 fires the moment it
is inside the pick-up area's box. The mission uses :class:`RobotInArea` beside navigation to
stop early — once the robot is inside the pick-up area and the guest answers on RFID there is
no reason to drive on to the goal, closer to a guest who is standing somewhere in the box (and
closer to the approximation penalty for crowding a person).
"""

from __future__ import annotations

from typing import Any

from py_trees.ports import NoDataAvailable, PortInformation

from bt_servicesim.behaviours.node import ConditionNode, Ports
from bt_servicesim.planning.geometry import Box, Pose2D

__all__ = ["RobotInArea"]


class RobotInArea(ConditionNode):
    """SUCCESS while the robot's origin is inside ``box`` shrunk by ``margin``, else FAILURE.

    Args:
        name: the behaviour's name
        margin: metres inside the box's edges the robot must be, so that odometry noise or a
            last bit of motion after the check cannot put it back outside
    """

    INPUT_PORTS: Ports = {
        "box": PortInformation(data_type=Box, required=True),
        "robot_pose": PortInformation(data_type=Pose2D, required=True),
    }
    OUTPUT_PORTS: Ports = {}

    def __init__(self, name: str = "RobotInArea", margin: float = 0.15, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.margin = float(margin)

    def check(self) -> bool:
        """Compare the pose with the box."""
        try:
            box: Box = self.get_input("box")
            pose: Pose2D = self.get_input("robot_pose")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot check the area: {error}"
            return False
        inside = box.contains(pose.x, pose.y, margin=self.margin)
        where = "inside" if inside else "outside"
        self.feedback_message = f"robot {where} the area ({pose.x:.2f}, {pose.y:.2f})"
        return inside
