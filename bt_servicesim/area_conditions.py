"""Conditions on where the robot stands relative to a target area.

The referee counts checkpoints by where the robot's origin is: checkpoint 1 fires the moment it
is inside the pick-up area's box. The mission uses :class:`RobotInArea` beside navigation to
stop early — once the robot is inside the pick-up area and the guest answers on RFID there is
no reason to drive on to the goal, closer to a guest who is standing somewhere in the box (and
closer to the approximation penalty for crowding a person).
"""

from typing import Any, ClassVar

import py_trees
from py_trees.ports import BehaviourWithPorts, NoDataAvailable, PortInformation

from bt_servicesim.geometry import Box, Pose2D

__all__ = ["RobotInArea"]

Status = py_trees.common.Status
Ports = dict[str, PortInformation]
"""A port declaration: port name to its information."""


class RobotInArea(BehaviourWithPorts):
    """SUCCESS while the robot's origin is inside ``box`` shrunk by ``margin``, else FAILURE.

    Args:
        name: the behaviour's name
        margin: metres inside the box's edges the robot must be, so that odometry noise or a
            last bit of motion after the check cannot put it back outside
    """

    INPUT_PORTS: ClassVar[Ports] = {
        "box": PortInformation(data_type=Box, required=True),
        "robot_pose": PortInformation(data_type=Pose2D, required=True),
    }
    OUTPUT_PORTS: ClassVar[Ports] = {}

    def __init__(self, name: str = "RobotInArea", margin: float = 0.15, **kwargs: Any) -> None:
        super().__init__(name=name, **kwargs)
        self.margin = float(margin)

    def update(self) -> Status:
        """Compare the pose with the box."""
        try:
            box, pose = self.get_input("box"), self.get_input("robot_pose")
        except NoDataAvailable as error:
            self.feedback_message = f"cannot check the area: {error}"
            return Status.FAILURE
        if box.contains(pose.x, pose.y, margin=self.margin):
            self.feedback_message = f"robot inside the area ({pose.x:.2f}, {pose.y:.2f})"
            return Status.SUCCESS
        self.feedback_message = f"robot outside the area ({pose.x:.2f}, {pose.y:.2f})"
        return Status.FAILURE
